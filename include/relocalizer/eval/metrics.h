#pragma once
// Accuracy measures of the relocalization literature (7-Scenes, TUM RGB-D).

#include <optional>
#include <vector>

#include "relocalizer/core/pose.h"

namespace relocalizer {

struct FrameError {
  int id = -1;
  bool has_pose = false;       // false: the relocalizer said "no pose"
  double translation_m = 0.0;  // +inf without a pose
  double rotation_deg = 0.0;   // +inf without a pose
};

FrameError frameError(int id, const std::optional<Pose>& estimate, const Pose& truth);

// "Correct within X cm / Y deg": both errors at most the tolerance (inclusive,
// as the 7-Scenes literature counts); a frame without a pose is never within.
struct PoseTolerance {
  double metres;
  double degrees;
};
inline constexpr PoseTolerance kCorrectPose{0.05, 5.0};  // "5 cm / 5 deg", the headline figure
inline constexpr PoseTolerance kFinePose{0.02, 2.0};     // "2 cm / 2 deg"
// An answer beyond this is wrong, not merely imprecise: a SLAM map that
// trusts it is corrupted.
inline constexpr PoseTolerance kWrongPose{0.10, 10.0};
// An answer (a frame with a pose) more than kWrongPose off its truth.
bool wrongAnswer(const FrameError& error);
bool within(const FrameError& error, PoseTolerance tolerance);

struct AccuracySummary {
  int frames = 0;
  int frames_with_pose = 0;
  // Shares of all frames within kCorrectPose and kFinePose; a frame without a
  // pose counts as a failure.
  double within_5cm_5deg = 0.0;
  double within_2cm_2deg = 0.0;
  // Frames answered more than kWrongPose off their truth (wrongAnswer).
  int wrong_answers = 0;
  // Medians over all frames, frames without a pose counting as infinite error
  // (so a median is infinite when more than half the frames have no pose).
  double median_translation_m = 0.0;
  double median_rotation_deg = 0.0;
  // Absolute trajectory error (TUM definition): RMSE of camera centres after
  // Horn's closed-form rigid alignment of the estimates onto the ground truth,
  // over frames with a pose. NaN with fewer than 3 such frames.
  double ate_rmse_m = 0.0;
};

// `estimates[i]` and `truths[i]` belong to `errors[i]`; estimates without a
// pose are ignored for the ATE.
AccuracySummary summarizeAccuracy(const std::vector<FrameError>& errors,
                                  const std::vector<std::optional<Pose>>& estimates,
                                  const std::vector<Pose>& truths);

// Rigid transform T minimising sum |T source_i - target_i|^2: Horn's (1987)
// closed form, computed by the one Kabsch (core/rigid_alignment.h). Needs at
// least 3 pairs (std::invalid_argument otherwise).
Pose hornAlignment(const std::vector<Eigen::Vector3d>& source,
                   const std::vector<Eigen::Vector3d>& target);

}  // namespace relocalizer
