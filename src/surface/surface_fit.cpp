#include "relocalizer/surface/surface_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "relocalizer/core/point_to_plane.h"

namespace relocalizer {

namespace {

bool liesOn(const SurfaceElement* element, const Eigen::Vector3f& world, float tolerance) {
  return element && std::abs(element->normal.dot(world - element->point)) <= tolerance;
}

}  // namespace

std::vector<Eigen::Vector3f> surfaceFitPoints(const RgbdFrame& frame, int count) {
  std::vector<Eigen::Vector3f> points;
  if (count <= 0 || frame.depth.empty()) return points;
  const int valid = countValidDepth(frame.depth);
  if (valid == 0) return points;
  // A grid over the valid pixels: every part of the view gets a say, unlike
  // random samples that cluster by chance.
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(valid) / count)));
  points.reserve(static_cast<size_t>(valid / (stride * stride) + 1));
  for (int v = stride / 2; v < frame.depth.rows; v += stride) {
    const float* row = frame.depth.ptr<float>(v);
    for (int u = stride / 2; u < frame.depth.cols; u += stride)
      if (row[u] > 0.0f)  // false for NaN
        points.push_back(
            frame.camera.backProject(static_cast<float>(u), static_cast<float>(v), row[u]));
  }
  return points;
}

float surfaceAgreement(const SurfaceModel& surface,
                       const std::vector<Eigen::Vector3f>& camera_points, const Pose& pose,
                       const SurfaceFitParams& params) {
  if (camera_points.empty() || surface.empty()) return 0.0f;
  const Eigen::Isometry3f to_world = pose.cast<float>();
  std::vector<Eigen::Vector3f> world(camera_points.size());
  for (size_t i = 0; i < world.size(); ++i) world[i] = to_world * camera_points[i];
  std::vector<const SurfaceElement*> elements(world.size());
  surface.nearAll(world.data(), world.size(), elements.data());
  int agreeing = 0;
  for (size_t i = 0; i < world.size(); ++i)
    agreeing += liesOn(elements[i], world[i], params.tolerance);
  return static_cast<float>(agreeing) / static_cast<float>(camera_points.size());
}

namespace {

// Whether the ray from `origin` along `direction` meets the surface between
// `from` and `to` metres: a sample within half a voxel of an element's plane.
// The samples are a voxel apart, so no plane is stepped over. They are looked
// up a batch at a time (SurfaceModel::nearAll: one-by-one lookups miss the
// cache in a large model), starting at the end `nearest_first` names: a
// surface is most often met near the measured point, and the first hit ends
// the walk with the verdict all the samples would give.
enum class WalkFrom { kStart, kEnd };

bool crossesSurface(const SurfaceModel& surface, const Eigen::Vector3f& origin,
                    const Eigen::Vector3f& direction, float from, float to, WalkFrom nearest_first,
                    std::vector<Eigen::Vector3f>& samples,
                    std::vector<const SurfaceElement*>& elements) {
  constexpr size_t kBatch = 16;
  const float step = surface.voxelSize();
  samples.clear();
  for (float t = std::max(from, step); t <= to; t += step)
    samples.push_back(origin + t * direction);
  if (nearest_first == WalkFrom::kEnd) std::reverse(samples.begin(), samples.end());
  elements.resize(kBatch);
  for (size_t first = 0; first < samples.size(); first += kBatch) {
    const size_t count = std::min(kBatch, samples.size() - first);
    surface.nearAll(samples.data() + first, count, elements.data());
    for (size_t k = 0; k < count; ++k)
      if (liesOn(elements[k], samples[first + k], 0.5f * step)) return true;
  }
  return false;
}

}  // namespace

SurfaceView viewSurface(const SurfaceModel& surface,
                        const std::vector<Eigen::Vector3f>& camera_points, const Pose& pose,
                        const SurfaceFitParams& params) {
  SurfaceView view;
  view.points = static_cast<int>(camera_points.size());
  if (surface.empty()) return view;
  const Eigen::Isometry3f to_world = pose.cast<float>();
  const Eigen::Vector3f origin = to_world.translation();
  std::vector<Eigen::Vector3f> world(camera_points.size());
  for (size_t i = 0; i < world.size(); ++i) world[i] = to_world * camera_points[i];
  std::vector<const SurfaceElement*> elements(world.size());
  surface.nearAll(world.data(), world.size(), elements.data());
  std::vector<Eigen::Vector3f> samples;
  std::vector<const SurfaceElement*> found;
  for (size_t i = 0; i < world.size(); ++i) {
    if (liesOn(elements[i], world[i], params.tolerance)) {
      ++view.on;
      continue;
    }
    const float depth = camera_points[i].norm();
    if (!(depth > 0.0f)) continue;
    const Eigen::Vector3f direction = (world[i] - origin) / depth;
    const float margin = params.occlusion_margin;
    if (crossesSurface(surface, origin, direction, 0.0f, depth - margin, WalkFrom::kEnd, samples,
                       found))
      ++view.behind;
    else if (crossesSurface(surface, origin, direction, depth + margin,
                            depth + params.occlusion_reach, WalkFrom::kStart, samples, found))
      ++view.in_front;
  }
  return view;
}

float SurfaceView::agreement() const {
  const int could_see = points - in_front;
  return could_see > 0 ? static_cast<float>(on) / static_cast<float>(could_see) : 0.0f;
}

std::string surfaceRefusal(const SurfaceView& view, const SurfaceFitParams& params) {
  const float all = static_cast<float>(std::max(1, view.points));
  const float on = view.on / all, in_front = view.in_front / all, behind = view.behind / all;
  char buffer[240];
  if (view.agreement() < params.min_agreement)
    std::snprintf(buffer, sizeof buffer,
                  "the pose does not fit the scene's surface: %.1f%% of the frame's depth "
                  "that is not in front of it lies on it (need %.1f%%)",
                  100.0 * view.agreement(), 100.0 * params.min_agreement);
  else if (on < params.min_on_surface)
    std::snprintf(buffer, sizeof buffer,
                  "too little of the scene's surface in view: %.1f%% of the frame's depth lies on "
                  "it, %.1f%% in front of it (need %.1f%% on it)",
                  100.0 * on, 100.0 * in_front, 100.0 * params.min_on_surface);
  else if (behind > params.max_seen_through)
    std::snprintf(buffer, sizeof buffer,
                  "the pose sees through the scene's surface: %.1f%% of the frame's depth lies "
                  "behind it (at most %.1f%%)",
                  100.0 * behind, 100.0 * params.max_seen_through);
  else
    return {};
  return buffer;
}

SurfaceFit fitToSurface(const SurfaceModel& surface,
                        const std::vector<Eigen::Vector3f>& camera_points, const Pose& initial,
                        const SurfaceFitParams& params) {
  SurfaceFit fit;
  fit.pose = initial;
  fit.points = static_cast<int>(camera_points.size());
  fit.initial_agreement = surfaceAgreement(surface, camera_points, initial, params);
  fit.agreement = fit.initial_agreement;
  if (surface.empty()) return fit;
  Pose pose = initial;
  std::vector<Eigen::Vector3d> world(camera_points.size());
  std::vector<Eigen::Vector3f> world_f(camera_points.size());
  std::vector<const SurfaceElement*> elements(camera_points.size());
  for (int it = 0; it < params.iterations; ++it) {
    for (size_t i = 0; i < world.size(); ++i) {
      world[i] = pose * camera_points[i].cast<double>();
      world_f[i] = world[i].cast<float>();
    }
    surface.nearAll(world_f.data(), world_f.size(), elements.data());
    PointToPlaneSystem system(params.huber);
    for (size_t i = 0; i < world.size(); ++i) {
      const SurfaceElement* element = elements[i];
      if (!element) continue;
      const Eigen::Vector3d& p = world[i];
      const Eigen::Vector3d normal = element->normal.cast<double>();
      const double r = normal.dot(p - element->point.cast<double>());
      if (std::abs(r) > params.max_distance) continue;
      system.add(p, normal, r);
    }
    fit.correspondences = system.count();
    if (system.count() < params.min_correspondences || !system.step(pose)) break;
  }
  const float agreement = surfaceAgreement(surface, camera_points, pose, params);
  // ICP that lost agreement slid along the surface into a wrong place.
  if (agreement >= fit.initial_agreement) {
    fit.refined = true;
    fit.pose = pose;
    fit.agreement = agreement;
  }
  fit.view = viewSurface(surface, camera_points, fit.pose, params);
  return fit;
}

}  // namespace relocalizer
