#include "relocalizer/online/place_change.h"

#include <algorithm>
#include <vector>

namespace relocalizer {

bool placeChanged(const SubmapLearner& submaps, const RgbdFrame& frame,
                  const Pose& camera_to_world) {
  // The caller is the one thread that changes the index.
  // What SubmapIndex::decide calls "covered": some frozen submap covers this pose.
  const std::vector<int> covering = submaps.index().coveringSubmaps(camera_to_world);
  if (covering.empty()) return false;
  std::vector<Eigen::Vector3f> points;
  bool compared = false;
  for (const SubmapModel& submap : submaps.models()) {
    if (!submap.relocalizer ||
        std::find(covering.begin(), covering.end(), submap.index) == covering.end())
      continue;
    const SurfaceModel& surface = submap.relocalizer->model().surface;
    if (surface.empty()) continue;
    const SurfaceFitParams& fit = submap.relocalizer->params().surface;
    if (points.empty()) points = surfaceFitPoints(frame, fit.points);
    compared = true;
    if (surfaceAgreement(surface, points, camera_to_world, fit) >=
        submaps.submapParams().relearn_agreement)
      return false;
  }
  return compared;
}

}  // namespace relocalizer
