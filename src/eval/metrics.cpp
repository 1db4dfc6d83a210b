#include "relocalizer/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "relocalizer/core/rigid_alignment.h"
#include "relocalizer/core/statistics.h"

namespace relocalizer {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

FrameError frameError(int id, const std::optional<Pose>& estimate, const Pose& truth) {
  FrameError e;
  e.id = id;
  e.has_pose = estimate.has_value();
  e.translation_m = e.has_pose ? translationError(*estimate, truth) : kInf;
  e.rotation_deg = e.has_pose ? rotationErrorDegrees(*estimate, truth) : kInf;
  return e;
}

bool within(const FrameError& error, PoseTolerance tolerance) {
  return error.has_pose && error.translation_m <= tolerance.metres &&
         error.rotation_deg <= tolerance.degrees;
}

bool wrongAnswer(const FrameError& error) { return error.has_pose && !within(error, kWrongPose); }

Pose hornAlignment(const std::vector<Eigen::Vector3d>& source,
                   const std::vector<Eigen::Vector3d>& target) {
  if (source.size() != target.size() || source.size() < 3)
    throw std::invalid_argument("hornAlignment needs at least 3 matched point pairs");
  Pose alignment = Pose::Identity();
  // A collinear trajectory leaves the rotation about its line free; any of the
  // equally good alignments gives the same residuals, which is all the ATE needs.
  kabsch(source.data(), target.data(), static_cast<int>(source.size()), alignment);
  return alignment;
}

AccuracySummary summarizeAccuracy(const std::vector<FrameError>& errors,
                                  const std::vector<std::optional<Pose>>& estimates,
                                  const std::vector<Pose>& truths) {
  AccuracySummary s;
  s.frames = static_cast<int>(errors.size());
  std::vector<double> translations, rotations;
  int within5 = 0, within2 = 0;
  for (const FrameError& e : errors) {
    translations.push_back(e.translation_m);
    rotations.push_back(e.rotation_deg);
    if (!e.has_pose) continue;
    ++s.frames_with_pose;
    within5 += within(e, kCorrectPose) ? 1 : 0;
    within2 += within(e, kFinePose) ? 1 : 0;
    s.wrong_answers += wrongAnswer(e) ? 1 : 0;
  }
  if (s.frames > 0) {
    s.within_5cm_5deg = static_cast<double>(within5) / s.frames;
    s.within_2cm_2deg = static_cast<double>(within2) / s.frames;
  }
  s.median_translation_m = median(translations);
  s.median_rotation_deg = median(rotations);

  std::vector<Eigen::Vector3d> estimated_centres, true_centres;
  for (size_t i = 0; i < estimates.size() && i < truths.size(); ++i) {
    if (!estimates[i]) continue;
    estimated_centres.push_back(estimates[i]->translation());
    true_centres.push_back(truths[i].translation());
  }
  if (estimated_centres.size() < 3) {
    s.ate_rmse_m = kNaN;
  } else {
    const Pose align = hornAlignment(estimated_centres, true_centres);
    double sum = 0.0;
    for (size_t i = 0; i < estimated_centres.size(); ++i)
      sum += (align * estimated_centres[i] - true_centres[i]).squaredNorm();
    s.ate_rmse_m = std::sqrt(sum / estimated_centres.size());
  }
  return s;
}

}  // namespace relocalizer
