#include "relocalizer/surface/surface_fit.h"

#include <algorithm>
#include <cmath>

#include "relocalizer/core/point_to_plane.h"

namespace relocalizer {

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
  for (size_t i = 0; i < world.size(); ++i) {
    const SurfaceElement* element = elements[i];
    if (element && std::abs(element->normal.dot(world[i] - element->point)) <= params.tolerance)
      ++agreeing;
  }
  return static_cast<float>(agreeing) / static_cast<float>(camera_points.size());
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
  return fit;
}

}  // namespace relocalizer
