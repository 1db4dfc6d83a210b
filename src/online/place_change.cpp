#include "relocalizer/online/place_change.h"

#include <algorithm>
#include <vector>

namespace relocalizer {

namespace {

// The most any of the submaps in `which` agrees with `frame`'s depth at
// `camera_to_world`; negative when none of them has a surface to compare with.
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

ViewKnowledge viewKnowledge(const SubmapLearner& submaps, const RgbdFrame& frame,
                            const Pose& camera_to_world) {
  // The caller is the one thread that changes the index.
  const SubmapIndex& index = submaps.index();
  const double enough = submaps.submapParams().relearn_agreement;
  const double survey = mostAgreement(submaps, index.surveyedSubmaps(), frame, camera_to_world);
  if (survey >= enough) return ViewKnowledge::kSurveyed;
  // What SubmapIndex::decide calls "covered": some frozen submap covers this pose.
  const std::vector<int> covering = index.coveringSubmaps(camera_to_world);
  const double learned = mostAgreement(submaps, covering, frame, camera_to_world);
  const double known = covering.empty() ? survey : learned;
  return known >= 0.0 && known < enough ? ViewKnowledge::kChanged : ViewKnowledge::kAsLearned;
}

}  // namespace relocalizer
