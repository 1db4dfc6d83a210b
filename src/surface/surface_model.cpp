#include "relocalizer/surface/surface_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace relocalizer {

namespace {

constexpr int kAxisBits = 21;
constexpr int64_t kAxisOffset = int64_t{1} << (kAxisBits - 1);
constexpr uint64_t kAxisMask = (uint64_t{1} << kAxisBits) - 1;
constexpr uint64_t kEmptyKey = std::numeric_limits<uint64_t>::max();

uint64_t packKey(int64_t x, int64_t y, int64_t z) {
  auto axis = [](int64_t i) {
    return static_cast<uint64_t>(std::clamp<int64_t>(i + kAxisOffset, 0, kAxisMask));
  };
  return axis(x) | (axis(y) << kAxisBits) | (axis(z) << (2 * kAxisBits));
}

Eigen::Matrix<int64_t, 3, 1> unpackKey(uint64_t key) {
  return {static_cast<int64_t>(key & kAxisMask) - kAxisOffset,
          static_cast<int64_t>((key >> kAxisBits) & kAxisMask) - kAxisOffset,
          static_cast<int64_t>((key >> (2 * kAxisBits)) & kAxisMask) - kAxisOffset};
}

uint64_t hashSlot(uint64_t key, uint64_t mask) {
  return ((key * 0x9E3779B97F4A7C15ULL) >> 17) & mask;
}

bool validDepth(float z, float max_depth) { return z > 0.0f && z <= max_depth; }  // false for NaN

}  // namespace

uint64_t surfaceVoxelKey(const Eigen::Vector3f& world, float voxel_size) {
  return packKey(static_cast<int64_t>(std::floor(world.x() / voxel_size)),
                 static_cast<int64_t>(std::floor(world.y() / voxel_size)),
                 static_cast<int64_t>(std::floor(world.z() / voxel_size)));
}

// --- Index ------------------------------------------------------------------------------

void SurfaceModel::Index::insert(uint64_t key, int32_t element) {
  for (uint64_t slot = hashSlot(key, mask);; slot = (slot + 1) & mask) {
    if (keys[slot] == kEmptyKey || keys[slot] == key) {
      keys[slot] = key;
      elements[slot] = element;
      return;
    }
  }
}

int32_t SurfaceModel::Index::find(uint64_t key) const {
  if (keys.empty()) return -1;
  for (uint64_t slot = hashSlot(key, mask);; slot = (slot + 1) & mask) {
    if (keys[slot] == key) return elements[slot];
    if (keys[slot] == kEmptyKey) return -1;
  }
}

void SurfaceModel::Index::prefetch(uint64_t key) const {
  if (!keys.empty()) {
    const uint64_t slot = hashSlot(key, mask);
    __builtin_prefetch(&keys[slot]);
    __builtin_prefetch(&elements[slot]);
  }
}

SurfaceModel::SurfaceModel(float voxel_size, std::vector<SurfaceElement> elements)
    : voxel_size_(voxel_size), elements_(std::move(elements)) {
  buildIndex();
}

void SurfaceModel::buildIndex() {
  index_ = {};
  if (elements_.empty()) return;
  std::unordered_map<uint64_t, int32_t> occupied;
  occupied.reserve(elements_.size());
  std::vector<uint64_t> element_keys(elements_.size());
  for (size_t i = 0; i < elements_.size(); ++i) {
    element_keys[i] = surfaceVoxelKey(elements_[i].point, voxel_size_);
    occupied.try_emplace(element_keys[i], static_cast<int32_t>(i));
  }
  // Empty voxels next to the surface point at the element nearest to their
  // centre, so that a point up to a voxel off the surface finds it in one probe.
  struct Candidate {
    int32_t element;
    float distance_squared;
  };
  std::unordered_map<uint64_t, Candidate> band;
  band.reserve(3 * elements_.size());
  for (size_t i = 0; i < elements_.size(); ++i) {
    const Eigen::Matrix<int64_t, 3, 1> voxel = unpackKey(element_keys[i]);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          const uint64_t key = packKey(voxel.x() + dx, voxel.y() + dy, voxel.z() + dz);
          if (occupied.count(key)) continue;
          const Eigen::Vector3f centre =
              (Eigen::Vector3f(voxel.x() + dx, voxel.y() + dy, voxel.z() + dz) +
               Eigen::Vector3f::Constant(0.5f)) *
              voxel_size_;
          const float d2 = (elements_[i].point - centre).squaredNorm();
          auto [it, added] = band.try_emplace(key, Candidate{static_cast<int32_t>(i), d2});
          // Ties go to the lower index: the band does not depend on hash order.
          if (!added &&
              (d2 < it->second.distance_squared ||
               (d2 == it->second.distance_squared && static_cast<int32_t>(i) < it->second.element)))
            it->second = {static_cast<int32_t>(i), d2};
        }
  }
  // At most half full: linear probing stays short.
  size_t capacity = 16;
  while (capacity < 2 * (occupied.size() + band.size())) capacity *= 2;
  index_.keys.assign(capacity, kEmptyKey);
  index_.elements.assign(capacity, -1);
  index_.mask = capacity - 1;
  for (const auto& [key, element] : occupied) index_.insert(key, element);
  for (const auto& [key, candidate] : band) index_.insert(key, candidate.element);
}

const SurfaceElement* SurfaceModel::near(const Eigen::Vector3f& world) const {
  const int32_t i = index_.find(surfaceVoxelKey(world, voxel_size_));
  return i >= 0 ? &elements_[static_cast<size_t>(i)] : nullptr;
}

void SurfaceModel::nearAll(const Eigen::Vector3f* world, size_t count,
                           const SurfaceElement** out) const {
  std::vector<uint64_t> keys(count);
  for (size_t i = 0; i < count; ++i) {
    keys[i] = surfaceVoxelKey(world[i], voxel_size_);
    index_.prefetch(keys[i]);
  }
  for (size_t i = 0; i < count; ++i) {
    const int32_t element = index_.find(keys[i]);
    out[i] = element >= 0 ? &elements_[static_cast<size_t>(element)] : nullptr;
    if (out[i]) __builtin_prefetch(out[i]);
  }
}

// --- Builder ----------------------------------------------------------------------------

void SurfaceBuilder::addFrame(const cv::Mat& depth, const CameraIntrinsics& camera,
                              const Pose& camera_to_world) {
  CV_Assert(depth.type() == CV_32FC1);
  const int frame = frames_++;
  const int step = std::max(1, params_.normal_step);
  const Eigen::Isometry3d& pose = camera_to_world;
  // Typed: an Eigen cast expression returned as `auto` would outlive its operand.
  auto point = [&](int u, int v, float z) -> Eigen::Vector3d {
    return camera.backProject(static_cast<float>(u), static_cast<float>(v), z).cast<double>();
  };
  for (int v = step; v + step < depth.rows; v += params_.pixel_stride) {
    for (int u = step; u + step < depth.cols; u += params_.pixel_stride) {
      const float z = depth.at<float>(v, u);
      if (!validDepth(z, params_.max_depth)) continue;
      const float zl = depth.at<float>(v, u - step), zr = depth.at<float>(v, u + step),
                  zu = depth.at<float>(v - step, u), zd = depth.at<float>(v + step, u);
      if (!(validDepth(zl, params_.max_depth) && validDepth(zr, params_.max_depth) &&
            validDepth(zu, params_.max_depth) && validDepth(zd, params_.max_depth)))
        continue;
      // A neighbour on another surface (a depth edge) would tilt the normal.
      const float edge = 0.05f * z;
      if (std::abs(zl - z) > edge || std::abs(zr - z) > edge || std::abs(zu - z) > edge ||
          std::abs(zd - z) > edge)
        continue;
      Eigen::Vector3d normal = (point(u + step, v, zr) - point(u - step, v, zl))
                                   .cross(point(u, v + step, zd) - point(u, v - step, zu));
      const double length = normal.norm();
      if (!(length > 0.0)) continue;
      const Eigen::Vector3d p = point(u, v, z);
      normal /= length;
      if (normal.dot(p) > 0.0) normal = -normal;  // towards the camera
      const Eigen::Vector3d world = pose * p;
      Voxel& voxel = voxels_[surfaceVoxelKey(world.cast<float>(), params_.voxel_size)];
      voxel.point_sum += world;
      voxel.normal_sum += pose.linear() * normal;
      ++voxel.points;
      if (voxel.last_frame != frame) {
        voxel.last_frame = frame;
        ++voxel.frames;
      }
    }
  }
}

SurfaceModel SurfaceBuilder::build() const {
  std::vector<std::pair<uint64_t, const Voxel*>> kept;
  kept.reserve(voxels_.size());
  for (const auto& [key, voxel] : voxels_)
    if (voxel.frames >= params_.min_frames) kept.emplace_back(key, &voxel);
  std::sort(kept.begin(), kept.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<SurfaceElement> elements;
  elements.reserve(kept.size());
  for (const auto& [key, voxel] : kept) {
    // Normals that cancel (a thin board seen from both sides) give no plane.
    const Eigen::Vector3d mean_normal = voxel->normal_sum / voxel->points;
    if (mean_normal.norm() < 0.5) continue;
    SurfaceElement element;
    element.point = (voxel->point_sum / voxel->points).cast<float>();
    element.normal = mean_normal.normalized().cast<float>();
    elements.push_back(element);
  }
  return SurfaceModel(params_.voxel_size, std::move(elements));
}

}  // namespace relocalizer
