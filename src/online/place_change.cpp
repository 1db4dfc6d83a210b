#include "relocalizer/online/place_change.h"

#include <algorithm>
#include <vector>

namespace relocalizer {

namespace {

// The most any of the submaps in `which` agrees with `frame`'s depth at
// `camera_to_world` (surface_fit.h, at each relocalizer's surface settings);
// negative when none of them has a surface to compare with. The caller is the
// one thread that changes the index.
double mostAgreement(const SubmapLearner& submaps, const std::vector<int>& which,
                     const RgbdFrame& frame, const Pose& camera_to_world) {
  double most = -1.0;
  if (which.empty()) return most;
  std::vector<Eigen::Vector3f> points;
  for (const SubmapModel& submap : submaps.models()) {
    if (!submap.relocalizer || std::find(which.begin(), which.end(), submap.index) == which.end())
      continue;
    const SurfaceModel& surface = submap.relocalizer->model().surface;
    if (surface.empty()) continue;
    const SurfaceFitParams& fit = submap.relocalizer->params().surface;
    if (points.empty()) points = surfaceFitPoints(frame, fit.points);
    most = std::max(most, double(surfaceAgreement(surface, points, camera_to_world, fit)));
    if (most >= submaps.submapParams().relearn_agreement) break;  // enough to decide
  }
  return most;
}

}  // namespace

bool placeChanged(const SubmapLearner& submaps, const RgbdFrame& frame,
                  const Pose& camera_to_world) {
  // What SubmapIndex::decide calls "covered": some frozen submap covers this pose.
  const double most = mostAgreement(submaps, submaps.index().coveringSubmaps(camera_to_world),
                                    frame, camera_to_world);
  return most >= 0.0 && most < submaps.submapParams().relearn_agreement;
}

bool surveyCovers(const SubmapLearner& submaps, const RgbdFrame& frame,
                  const Pose& camera_to_world) {
  return mostAgreement(submaps, submaps.index().surveyedSubmaps(), frame, camera_to_world) >=
         submaps.submapParams().relearn_agreement;
}

}  // namespace relocalizer
