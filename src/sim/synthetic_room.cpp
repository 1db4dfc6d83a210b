// Rendering the synthetic room: ray casting through the BVH, shading and the
// Kinect depth model (time-varying effects: room_effects.cpp; camera paths:
// room_trajectories.cpp).

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>
#include <initializer_list>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "room_changes.h"
#include "room_effects.h"
#include "room_trajectories.h"
#include "synthetic_textures.h"

namespace relocalizer {

using namespace synthetic;

// ---------------------------------------------------------------- ray casting

Hit SyntheticRoom::Impl::trace(const Ray& r, const FrameState* frame) const {
  Hit hit;
  // The shell: nearest exit through the room's faces, for origins inside.
  for (int k = 0; k < 3; ++k) {
    if (r.d[k] == 0.0f) continue;
    const bool positive = r.d[k] > 0.0f;
    const float t = ((positive ? hi[k] : lo[k]) - r.o[k]) * r.inv[k];
    if (t > 0.0f && t < hit.t) {
      hit.t = t;
      hit.face = faceIndex(k, positive);
    }
  }
  if (!nodes.empty()) {
    // Nearer children first, and entries kept with their distance so subtrees
    // behind a hit found meanwhile are skipped. Stack entries >= 0 are nodes,
    // negative ones leaves: -1 - (first box * 8 + box count).
    int stack_item[96];
    float stack_t[96];
    int top = 0;
    stack_item[0] = 0;
    stack_t[top++] = 0.0f;
    const float ox = r.o.x(), oy = r.o.y(), oz = r.o.z();
    const float ix = r.inv.x(), iy = r.inv.y(), iz = r.inv.z();
    while (top > 0) {
      --top;
      if (stack_t[top] > hit.t) continue;
      const int item = stack_item[top];
      if (item < 0) {
        const int first = (-1 - item) >> 3, count = (-1 - item) & 7;
        for (int i = first; i < first + count; ++i) {
          float t;
          int face;
          if (intersectBox(boxes[i], r, t, face) &&
              (t < hit.t || (t == hit.t && hit.box >= 0 && boxes[i].id < hit.id))) {
            hit.t = t;
            hit.box = i;
            hit.face = face;
            hit.id = boxes[i].id;
          }
        }
        continue;
      }
      const WideNode& node = nodes[item];
      float entry[4];
      for (int k = 0; k < 4; ++k) {
        const float x0 = (node.lo[0][k] - ox) * ix, x1 = (node.hi[0][k] - ox) * ix;
        const float y0 = (node.lo[1][k] - oy) * iy, y1 = (node.hi[1][k] - oy) * iy;
        const float z0 = (node.lo[2][k] - oz) * iz, z1 = (node.hi[2][k] - oz) * iz;
        const float t_near = std::max(std::max(std::min(x0, x1), std::min(y0, y1)),
                                      std::max(std::min(z0, z1), 0.0f));
        const float t_far = std::min(std::min(std::max(x0, x1), std::max(y0, y1)),
                                     std::min(std::max(z0, z1), hit.t));
        entry[k] = t_near <= t_far ? t_near : kInf;
      }
      // Up to four children sorted far to near, then pushed so the nearest pops first.
      int order[4], n = 0;
      for (int k = 0; k < 4; ++k) {
        if (node.count[k] < 0 || entry[k] == kInf) continue;
        int j = n++;
        for (; j > 0 && entry[order[j - 1]] < entry[k]; --j) order[j] = order[j - 1];
        order[j] = k;
      }
      for (int j = 0; j < n; ++j) {
        const int k = order[j];
        stack_item[top] =
            node.count[k] > 0 ? -1 - (node.child[k] * 8 + node.count[k]) : node.child[k];
        stack_t[top++] = entry[k];
      }
    }
  }
  if (frame) {
    for (int i = 0; i < frame->mover_count; ++i) {
      float t;
      int face;
      if (intersectBox(frame->movers[i], r, t, face) && t < hit.t) {
        hit.t = t;
        hit.box = -2 - i;
        hit.face = face;
      }
    }
  }
  if (hit.face == kNoFace) hit.t = kInf;
  return hit;
}

Vec3f SyntheticRoom::Impl::shade(const Ray& r, const Hit& hit, const FrameState& frame,
                                 bool& gives_depth) const {
  const Vec3f p = r.o + r.d * hit.t;
  const int axis = hit.face / 2;
  const bool positive_side = (hit.face & 1) != 0;
  const int ua = kFaceU[axis], va = kFaceV[axis];
  Vec3f normal = Vec3f::Zero();
  int m;
  float u, v, width, height;
  if (hit.box == -1) {  // the shell faces inward
    normal[axis] = positive_side ? -1.0f : 1.0f;
    m = shell_material[hit.face];
    u = p[ua] - lo[ua];
    v = p[va] - lo[va];
    width = hi[ua] - lo[ua];
    height = hi[va] - lo[va];
  } else {
    const Box& box = hitBox(hit, &frame);
    const Vec3f local = box.toLocal(p - box.centre) + box.half;
    Vec3f local_normal = Vec3f::Zero();
    local_normal[axis] = positive_side ? 1.0f : -1.0f;
    normal = box.toWorld(local_normal);
    m = box.material[hit.face];
    u = local[ua];
    v = local[va];
    width = 2 * box.half[ua];
    height = 2 * box.half[va];
  }
  const Material& material = materials[m];
  const Vec3f albedo_rgb = albedo(material, shapes, u, v, width, height);
  gives_depth = material.gives_depth &&
                (0.3f * albedo_rgb.x() + 0.59f * albedo_rgb.y() + 0.11f * albedo_rgb.z()) > 0.05f;
  if (material.pattern == Pattern::kSky) return albedo_rgb.cwiseProduct(frame.gain);  // outdoors
  Vec3f irradiance = frame.ambient;
  for (int i = 0; i < light_count; ++i) {
    const Vec3f to_light = lights[i].position - p;
    const float d2 = to_light.squaredNorm();
    const float cosine = normal.dot(to_light) / std::sqrt(d2);
    if (cosine > 0.0f)
      irradiance += frame.light_colour[i] * (cosine / (1.0f + lights[i].falloff * d2));
  }
  return albedo_rgb.cwiseProduct(irradiance).cwiseProduct(frame.gain);
}

// ---------------------------------------------------------------- public API

double KinectDepthModel::quantise(double z) {
  if (!(z > 0)) return z;
  const double disparity = kBaselineFocal / z;
  const double steps = std::floor(disparity / kDisparityStep + 0.5);
  return steps > 0 ? kBaselineFocal / (steps * kDisparityStep)
                   : std::numeric_limits<double>::infinity();
}

SyntheticRoom::SyntheticRoom(uint64_t seed) : SyntheticRoom(RoomRecipe{seed, seed}) {}

SyntheticRoom::SyntheticRoom(const RoomRecipe& recipe) {
  auto impl = std::make_shared<Impl>();
  impl->seed = recipe.layout_seed;
  impl->appearance_seed = recipe.appearance_seed;
  buildRoom(*impl);
  impl_ = std::move(impl);
}

uint64_t SyntheticRoom::seed() const { return impl_->seed; }
uint64_t SyntheticRoom::appearanceSeed() const { return impl_->appearance_seed; }

Eigen::AlignedBox3d SyntheticRoom::bounds() const {
  return {impl_->lo.cast<double>(), impl_->hi.cast<double>()};
}

RoomDoor SyntheticRoom::door() const { return impl_->door; }

SyntheticTrajectories SyntheticRoom::trajectories(int train_frames, int test_frames) const {
  return roomTrajectories(*impl_, train_frames, test_frames);
}

SyntheticRoom SyntheticRoom::changed(const SceneChanges& changes) const {
  const std::string error = changes.validationError();
  if (!error.empty()) throw std::invalid_argument("SyntheticRoom::changed: " + error);
  if (!changes.any()) return *this;
  auto impl = std::make_shared<Impl>(*impl_);
  applyChanges(*impl, changes);
  SyntheticRoom room = *this;
  room.impl_ = std::move(impl);
  return room;
}

SceneChanges SyntheticRoom::changes() const { return impl_->changes; }

int SyntheticRoom::boxCount() const { return static_cast<int>(impl_->boxes.size()); }

namespace {

uint64_t hashFloats(uint64_t h, std::initializer_list<float> values) {
  for (const float v : values) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    h = mix64(h ^ bits);
  }
  return h;
}

uint64_t materialFingerprint(const SyntheticRoom::Impl& room, const Material& m) {
  uint64_t h = mix64(static_cast<uint64_t>(m.pattern) ^ (uint64_t{m.seed} << 8) ^
                     (static_cast<uint64_t>(m.variant) << 40) ^ (m.gives_depth ? 1ULL << 60 : 0));
  h = hashFloats(h, {m.a.x(), m.a.y(), m.a.z(), m.b.x(), m.b.y(), m.b.z(), m.c.x(), m.c.y(),
                     m.c.z(), m.scale});
  for (int i = m.shapes_begin; i < m.shapes_begin + m.shapes_count; ++i) {
    const Shape& s = room.shapes[i];
    h = hashFloats(mix64(h ^ s.kind),
                   {s.x, s.y, s.rx, s.ry, s.colour.x(), s.colour.y(), s.colour.z()});
  }
  return h;
}

}  // namespace

std::vector<RoomBox> SyntheticRoom::boxes() const {
  // The BVH has reordered the boxes; their ids are their creation order.
  std::vector<RoomBox> result(impl_->boxes.size());
  for (const Box& box : impl_->boxes) {
    RoomBox& b = result[box.id];
    b.centre = box.centre.cast<double>();
    b.half_size = box.half.cast<double>();
    b.yaw = std::atan2(box.sin_yaw, box.cos_yaw);
    uint64_t h = 0;
    for (const int m : box.material)
      h = mix64(h ^ materialFingerprint(*impl_, impl_->materials[m]));
    b.appearance = h;
  }
  return result;
}

namespace {

// Rays through pixel centres with direction (x/z, y/z, 1) in the camera
// frame, so the hit parameter is the depth along the optical axis.
struct PixelRays {
  Vec3f origin;
  Eigen::Matrix3f rotation;
  float fx, fy, cx, cy;
  PixelRays(const Pose& pose, const CameraIntrinsics& camera)
      : origin(pose.translation().cast<float>()),
        rotation(pose.linear().cast<float>()),
        fx(static_cast<float>(camera.fx)),
        fy(static_cast<float>(camera.fy)),
        cx(static_cast<float>(camera.cx)),
        cy(static_cast<float>(camera.cy)) {}
  Ray at(int u, int v) const {
    return Ray(origin, rotation * Vec3f((u - cx) / fx, (v - cy) / fy, 1.0f));
  }
};

// 64 random bits per (seed, frame, pixel): the depth noise needs no state, so
// rows can be rendered in any order on any number of threads.
inline uint64_t pixelKey(uint64_t seed, int frame_index, int u, int v) {
  uint64_t h = mix64(seed ^ 0xD1B54A32D192ED03ULL);
  h = mix64(h ^
            (static_cast<uint64_t>(static_cast<uint32_t>(frame_index)) * 0x9E3779B97F4A7C15ULL));
  return mix64(
      h ^ ((static_cast<uint64_t>(static_cast<uint32_t>(v)) << 32) | static_cast<uint32_t>(u)));
}

void checkCamera(const CameraIntrinsics& camera) {
  const std::string error = camera.validationError();
  if (!error.empty()) throw std::invalid_argument("SyntheticRoom: " + error);
}

}  // namespace

RgbdFrame SyntheticRoom::render(const Pose& camera_to_world, const CameraIntrinsics& camera,
                                int frame_index, const RenderEffects& effects) const {
  checkCamera(camera);
  const Impl& room = *impl_;
  const Impl::FrameState state = frameState(room, frame_index, effects);
  const int width = camera.width, height = camera.height;
  cv::Mat colour(height, width, CV_8UC3);
  cv::Mat exact(height, width, CV_32FC1);
  cv::Mat depth_ok(height, width, CV_8UC1);

  const PixelRays rays(camera_to_world, camera);
  std::vector<PixelRays> blur_rays;
  for (const Pose& p : effects.motion_blur_poses) blur_rays.emplace_back(p, camera);

  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      auto* c_row = colour.ptr<uint8_t>(v);
      auto* z_row = exact.ptr<float>(v);
      auto* ok_row = depth_ok.ptr<uint8_t>(v);
      for (int u = 0; u < width; ++u) {
        const Ray ray = rays.at(u, v);
        const Hit hit = room.trace(ray, &state);
        bool gives_depth = false;
        Vec3f rgb = Vec3f::Zero();
        if (std::isfinite(hit.t)) rgb = room.shade(ray, hit, state, gives_depth);
        z_row[u] = std::isfinite(hit.t) ? hit.t : kNaN;
        ok_row[u] = gives_depth ? 1 : 0;
        if (!blur_rays.empty()) {
          rgb.setZero();
          for (const PixelRays& br : blur_rays) {
            const Ray sub = br.at(u, v);
            const Hit sub_hit = room.trace(sub, &state);
            bool ignored;
            if (std::isfinite(sub_hit.t)) rgb += room.shade(sub, sub_hit, state, ignored);
          }
          rgb /= static_cast<float>(blur_rays.size());
        }
        for (int ch = 0; ch < 3; ++ch)
          c_row[3 * u + 2 - ch] =
              static_cast<uint8_t>(std::clamp(rgb[ch], 0.0f, 1.0f) * 255.0f + 0.5f);
      }
    }
  });

  cv::Mat depth(height, width, CV_32FC1);
  if (!effects.depth_noise) {
    exact.copyTo(depth);
  } else {
    // Structured light fails where neighbouring depths jump: mark both sides
    // of every jump over 5 %, drop pixels within ~2 px (at 640 wide) of one,
    // and half of those one pixel further out, for a ragged Kinect-like rim.
    cv::Mat edge = cv::Mat::zeros(height, width, CV_8UC1);
    for (int v = 0; v < height; ++v) {
      const float* z = exact.ptr<float>(v);
      const float* z_down = v + 1 < height ? exact.ptr<float>(v + 1) : nullptr;
      uint8_t* e = edge.ptr<uint8_t>(v);
      uint8_t* e_down = v + 1 < height ? edge.ptr<uint8_t>(v + 1) : nullptr;
      for (int u = 0; u < width; ++u) {
        if (u + 1 < width && !(std::abs(z[u + 1] - z[u]) <= 0.05f * std::min(z[u], z[u + 1])))
          e[u] = e[u + 1] = 1;
        if (z_down && !(std::abs(z_down[u] - z[u]) <= 0.05f * std::min(z[u], z_down[u])))
          e[u] = e_down[u] = 1;
      }
    }
    const int radius = std::max(1, static_cast<int>(std::lround(2.0 * width / 640.0)));
    cv::Mat near_edge, rim;
    cv::dilate(edge, near_edge,
               cv::getStructuringElement(cv::MORPH_RECT, {2 * radius - 1, 2 * radius - 1}));
    cv::dilate(edge, rim,
               cv::getStructuringElement(cv::MORPH_RECT, {2 * radius + 1, 2 * radius + 1}));
    const float mm_to_m = static_cast<float>(1.0 / 1000.0);  // as depthToMetres scales
    const uint64_t seed = room.seed;
    tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
      for (int v = rows.begin(); v < rows.end(); ++v) {
        const float* z = exact.ptr<float>(v);
        const uint8_t* ok = depth_ok.ptr<uint8_t>(v);
        const uint8_t* near = near_edge.ptr<uint8_t>(v);
        const uint8_t* outer = rim.ptr<uint8_t>(v);
        float* out = depth.ptr<float>(v);
        for (int u = 0; u < width; ++u) {
          out[u] = kNaN;
          if (!ok[u] || near[u] || !std::isfinite(z[u])) continue;
          const uint64_t key = pixelKey(seed, frame_index, u, v);
          if (outer[u] && (key >> 63)) continue;
          // Box-Muller from two 24-bit uniforms; u1 > 0 keeps the log finite.
          const float u1 = (static_cast<float>((key >> 8) & 0xFFFFFF) + 1.0f) * 0x1.0p-24f;
          const float u2 = static_cast<float>((key >> 32) & 0xFFFFFF) * 0x1.0p-24f;
          const double gauss = std::sqrt(-2.0f * std::log(u1)) * std::cos(kTwoPi * u2);
          const double noisy = z[u] + KinectDepthModel::noiseSigma(z[u]) * gauss;
          const double quantised = KinectDepthModel::quantise(noisy);
          if (!(quantised >= KinectDepthModel::kMinDepth &&
                quantised <= KinectDepthModel::kMaxDepth))
            continue;
          const int mm = static_cast<int>(quantised * 1000.0 + 0.5);
          out[u] = static_cast<float>(mm) * mm_to_m;
        }
      }
    });
  }

  RgbdFrame frame;
  frame.colour = colour;
  frame.depth = depth;
  frame.camera = camera;
  frame.stamp = frame_index;
  frame.id = frame_index;
  frame.ground_truth = camera_to_world;
  frame.source = "synthetic room (seed " + std::to_string(room.seed) + ")";
  return frame;
}

cv::Mat SyntheticRoom::exactDepth(const Pose& camera_to_world,
                                  const CameraIntrinsics& camera) const {
  checkCamera(camera);
  const Impl& room = *impl_;
  cv::Mat depth(camera.height, camera.width, CV_32FC1);
  const PixelRays rays(camera_to_world, camera);
  tbb::parallel_for(tbb::blocked_range<int>(0, camera.height),
                    [&](const tbb::blocked_range<int>& rows) {
                      for (int v = rows.begin(); v < rows.end(); ++v) {
                        float* out = depth.ptr<float>(v);
                        for (int u = 0; u < camera.width; ++u) {
                          const Hit hit = room.trace(rays.at(u, v), nullptr);
                          out[u] = std::isfinite(hit.t) ? hit.t : kNaN;
                        }
                      }
                    });
  return depth;
}

std::optional<double> SyntheticRoom::castRay(const Eigen::Vector3d& origin,
                                             const Eigen::Vector3d& direction) const {
  const Impl& room = *impl_;
  const Eigen::AlignedBox3d inside = bounds();
  if (!inside.contains(origin) || !(direction.squaredNorm() > 0)) return std::nullopt;
  const Hit hit = room.trace(Ray(origin.cast<float>(), direction.cast<float>()), nullptr);
  if (!std::isfinite(hit.t)) return std::nullopt;
  return static_cast<double>(hit.t);
}

double SyntheticRoom::surfaceDistance(const Eigen::Vector3d& point) const {
  const Impl& room = *impl_;
  const Vec3f p = point.cast<float>();
  float best = std::min((p - room.lo).minCoeff(), (room.hi - p).minCoeff());
  best = std::abs(best);
  for (const Box& box : room.boxes) best = std::min(best, boxDistance(box, p));
  return best;
}

}  // namespace relocalizer
