#include "relocalizer/online/place_change.h"

#include <algorithm>
#include <vector>

namespace relocalizer {

namespace {

// One key frame compared with the surfaces of the submaps: the models and the
// frame's depth points are taken once, however many submaps it meets.
class SurfaceComparison {
 public:
  SurfaceComparison(const SubmapLearner& submaps, const RgbdFrame& frame,
                    const Pose& camera_to_world)
      : models_(submaps.models()),
        frame_(frame),
        camera_to_world_(camera_to_world),
        enough_(submaps.submapParams().relearn_agreement) {}

  // The most any of the submaps in `which` agrees with the frame's depth;
  // negative when none of them has a surface to compare with.
  double mostAgreement(const std::vector<int>& which) {
    double most = -1.0;
    for (const SubmapModel& submap : models_) {
      if (!submap.relocalizer || std::find(which.begin(), which.end(), submap.index) == which.end())
        continue;
      const SurfaceModel& surface = submap.relocalizer->model().surface;
      if (surface.empty()) continue;
      const SurfaceFitParams& fit = submap.relocalizer->params().surface;
      if (points_.empty()) points_ = surfaceFitPoints(frame_, fit.points);
      most = std::max(most, double(surfaceAgreement(surface, points_, camera_to_world_, fit)));
      if (most >= enough_) break;  // enough to decide
    }
    return most;
  }

 private:
  const std::vector<SubmapModel> models_;
  const RgbdFrame& frame_;
  const Pose& camera_to_world_;
  const double enough_;
  std::vector<Eigen::Vector3f> points_;
};

}  // namespace

ViewKnowledge viewKnowledge(const SubmapLearner& submaps, const RgbdFrame& frame,
                            const Pose& camera_to_world) {
  // The caller is the one thread that changes the index.
  const SubmapIndex& index = submaps.index();
  const double enough = submaps.submapParams().relearn_agreement;
  SurfaceComparison compare(submaps, frame, camera_to_world);
  const double survey = compare.mostAgreement(index.surveyedSubmaps());
  if (survey >= enough) return ViewKnowledge::kSurveyed;
  // What SubmapIndex::decide calls "covered": some frozen submap covers this pose.
  const std::vector<int> covering = index.coveringSubmaps(camera_to_world);
  const double known = covering.empty() ? survey : compare.mostAgreement(covering);
  return known >= 0.0 && known < enough ? ViewKnowledge::kChanged : ViewKnowledge::kAsLearned;
}

}  // namespace relocalizer
