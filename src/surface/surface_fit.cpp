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
  int agreeing = 0;
  for (const Eigen::Vector3f& c : camera_points) {
    const Eigen::Vector3f p = to_world * c;
    const SurfaceElement* element = surface.near(p);
    if (element && std::abs(element->normal.dot(p - element->point)) <= params.tolerance)
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
  for (int it = 0; it < params.iterations; ++it) {
    PointToPlaneSystem system(params.huber);
    for (const Eigen::Vector3f& c : camera_points) {
      const Eigen::Vector3d p = pose * c.cast<double>();
      const SurfaceElement* element = surface.near(p.cast<float>());
      if (!element) continue;
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
