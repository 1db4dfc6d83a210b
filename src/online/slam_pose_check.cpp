#include "relocalizer/online/slam_pose_check.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "relocalizer/core/number_list.h"

namespace relocalizer {
namespace {

// How far the learned place's own answer may be from SLAM's pose when the
// depth images cannot tell: a learned place answers to a few centimetres, and
// the jumps this guards against are metres.
constexpr double kPlaceAgreementMetres = 0.1;
constexpr double kPlaceAgreementDegrees = 10.0;

// The longest motion between two key frames the depth images judge; beyond
// it the place is asked.
constexpr double kDepthRangeMetres = 0.3;
constexpr double kDepthRangeDegrees = 20.0;

// About 5000 samples a frame whatever its size: the alignment then costs the
// same at 640 x 480 as at 320 x 240, and 5000 points pin a rigid motion.
DepthAlignmentParams alignmentParams(const cv::Mat& depth) {
  DepthAlignmentParams params;
  params.stride = std::max(2, static_cast<int>(std::lround(std::sqrt(depth.total() / 5000.0))));
  params.iterations = 15;
  return params;
}

std::string describe(const PoseDifference& d) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f m / %.1f deg", d.translation, d.rotation_deg);
  return text;
}

std::string position(const Pose& pose) {
  char text[96];
  const Eigen::Vector3d t = pose.translation();
  std::snprintf(text, sizeof text, "(%.2f, %.2f, %.2f)", t.x(), t.y(), t.z());
  return text;
}

bool sameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width &&
         a.height == b.height;
}

}  // namespace

std::string slamPoseError(const Pose& pose) {
  if (!pose.matrix().allFinite()) return "SLAM pose is not finite (NaN or Inf)";
  const Eigen::Matrix3d r = pose.linear();
  // SLAM's quaternions arrive as doubles, normalised to far better than this.
  constexpr double kTolerance = 1e-3;
  const double off_orthonormal =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off_orthonormal > kTolerance || std::abs(r.determinant() - 1.0) > kTolerance)
    return "SLAM pose's rotation is not a rotation (det " + std::to_string(r.determinant()) +
           ", off orthonormal by " + std::to_string(off_orthonormal) + ")";
  const double distance = pose.translation().norm();
  if (distance > kMaxSlamPoseDistance) {
    char text[64];
    std::snprintf(text, sizeof text, "%.3g", distance);
    return std::string("SLAM pose is ") + text + " m from the map origin (at most " +
           std::to_string(static_cast<int>(kMaxSlamPoseDistance)) + " m is learned)";
  }
  return {};
}

std::string slamCheckParamsError(const SlamCheckParams& p, const SettingName& name) {
  const auto positive = [](double value) { return value > 0.0 && std::isfinite(value); };
  if (!positive(p.max_speed) || !positive(p.max_turn))
    return settingName(name, "max_slam_speed") +
           " must be finite and > 0 (metres and degrees per second; got " +
           std::to_string(p.max_speed) + "," + std::to_string(p.max_turn) + ")";
  if (!positive(p.max_disagreement_metres) || !positive(p.max_disagreement_degrees))
    return settingName(name, "slam_disagreement") +
           " must be finite and > 0 (metres and degrees; got " +
           std::to_string(p.max_disagreement_metres) + "," +
           std::to_string(p.max_disagreement_degrees) + ")";
  return {};
}

Status readSlamCheckBounds(const std::string& speed, const std::string& disagreement,
                           SlamCheckParams& params, const SettingName& name) {
  const auto pair = [&](const std::string& field, const std::string& text, double& metres,
                        double& degrees) -> Status {
    auto values = parseNumberList(text);
    if (!values || values->size() != 2)
      return makeError(settingName(name, field) + ": '" + text +
                       "' is not two numbers METRES,DEGREES" +
                       (values ? std::string() : " (" + values.error() + ")"));
    metres = (*values)[0];
    degrees = (*values)[1];
    return okStatus();
  };
  if (Status read = pair("max_slam_speed", speed, params.max_speed, params.max_turn); !read)
    return read;
  if (Status read = pair("slam_disagreement", disagreement, params.max_disagreement_metres,
                         params.max_disagreement_degrees);
      !read)
    return read;
  if (std::string why = slamCheckParamsError(params, name); !why.empty()) return makeError(why);
  return okStatus();
}

SlamPoseCheck::SlamPoseCheck(SlamCheckParams params) : params_(params) {}

SlamPoseCheck::Verdict SlamPoseCheck::depthVerdict(const Seen& from, const Seen& to) const {
  if (from.depth.empty() || from.depth.size() != to.depth.size() ||
      !sameCamera(from.camera, to.camera))
    return {Verdict::Unconfirmed, "the two key frames' depth images differ in size or camera"};
  const Pose claimed = from.pose.inverse() * to.pose;  // `to` camera -> `from` camera
  const PoseDifference motion = poseDifference(Pose::Identity(), claimed);
  // Projective ICP is sure of itself only over a short motion: across a gap
  // of 0.86 m / 12 deg in redkitchen's ground truth (frames 299 -> 400) it
  // settled 6-9 cm from the truth.
  if (motion.translation > kDepthRangeMetres || motion.rotation_deg > kDepthRangeDegrees)
    return {Verdict::Unconfirmed, "SLAM's motion since the last key frame, " + describe(motion) +
                                      ", is too long for the depth images to check"};
  const DepthAlignment aligned =
      alignDepth(from.depth, to.depth, to.camera, claimed, alignmentParams(to.depth));
  if (!aligned.valid)
    // Or a view the alignment cannot pin (one wall): not a contradiction.
    return {Verdict::Unconfirmed, "the depth images do not overlap where SLAM's motion of " +
                                      describe(motion) + " puts them"};
  const PoseDifference off = poseDifference(claimed, aligned.motion);
  if (off.translation <= params_.max_disagreement_metres &&
      off.rotation_deg <= params_.max_disagreement_degrees)
    return {Verdict::Confirmed, {}};
  return {Verdict::Refuted, "the depth images show a motion " + describe(off) +
                                " away from SLAM's " + describe(motion)};
}

SlamPoseCheck::Verdict SlamPoseCheck::judge(const Seen& seen, const RgbdFrame& frame,
                                            const AskPlace& answer) const {
  Verdict depth{Verdict::Unconfirmed, {}};
  if (reference_) {
    const PoseDifference moved = poseDifference(reference_->pose, seen.pose);
    const double seconds = seen.stamp - reference_->stamp;
    if (seconds > 0 && (moved.translation > params_.max_speed * seconds ||
                        moved.rotation_deg > params_.max_turn * seconds)) {
      char text[192];
      std::snprintf(text, sizeof text,
                    "SLAM moved the camera %s in %.3f s since the last key frame (at most %g m/s "
                    "and %g deg/s)",
                    describe(moved).c_str(), seconds, params_.max_speed, params_.max_turn);
      return {Verdict::Refuted, text};
    }
    // A SLAM system that resets starts its new map where the camera is.
    const PoseDifference from_origin = poseDifference(Pose::Identity(), seen.pose);
    if (from_origin.translation < 1e-3 && from_origin.rotation_deg < 0.1 &&
        moved.translation > params_.max_disagreement_metres)
      return {Verdict::Refuted, "SLAM put the camera back at the map origin (a map reset?), " +
                                    describe(moved) + " from the last key frame"};
    depth = depthVerdict(*reference_, seen);
    if (depth.outcome != Verdict::Unconfirmed) return depth;
  }
  // The images cannot tell (or there is nothing to compare with yet): the
  // learned place, when it knows the frame, must put it where SLAM does.
  const std::optional<Pose> placed = answer ? answer(frame) : std::nullopt;
  if (placed) {
    const PoseDifference off = poseDifference(*placed, seen.pose);
    if (off.translation <= kPlaceAgreementMetres && off.rotation_deg <= kPlaceAgreementDegrees)
      return {Verdict::Confirmed, {}};
    return {Verdict::Refuted,
            "the learned place puts the frame " + describe(off) + " from SLAM's pose"};
  }
  if (!reference_)
    return {Verdict::Confirmed, {}};  // the first key frame, of a place that does not know it
  return {Verdict::Unconfirmed, depth.why + ", and the learned place does not know the frame"};
}

void SlamPoseCheck::follow(Seen seen) {
  reference_ = std::move(seen);
  candidate_.reset();
  refused_in_a_row_ = 0;
}

std::string SlamPoseCheck::check(const RgbdFrame& frame, const Pose& camera_to_world,
                                 const AskPlace& answer, const StartNewPlace& new_place) {
  Seen seen{camera_to_world, frame.stamp, frame.depth, frame.camera};
  if (!params_.enabled) return {};
  const auto start = std::chrono::steady_clock::now();
  const bool had_reference = reference_.has_value();
  const Verdict verdict = judge(seen, frame, answer);
  std::string why;
  bool run_learned = false;
  if (verdict.outcome == Verdict::Confirmed) {
    follow(std::move(seen));
  } else {
    why = verdict.why;
    run_learned = refused(std::move(seen), verdict, new_place, why);
  }
  std::lock_guard<std::mutex> lock(status_mutex_);
  status_.check_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  status_.checked += had_reference;
  status_.runs_learned += run_learned;
  if (why.empty()) status_.map_moved = false;
  return why;
}

bool SlamPoseCheck::refused(Seen seen, const Verdict& verdict, const StartNewPlace& new_place,
                            std::string& why) {
  const bool agrees = candidate_ && depthVerdict(*candidate_, seen).outcome == Verdict::Confirmed;
  if (!agrees) {
    refused_in_a_row_ = 0;
    run_start_ = seen.stamp;
    run_told_ = false;
    run_refuted_ = false;
  }
  ++refused_in_a_row_;
  run_refuted_ = run_refuted_ || verdict.outcome == Verdict::Refuted;
  const double run_seconds = seen.stamp - run_start_;
  const bool persisted = refused_in_a_row_ >= kMapMovedKeyFrames && run_seconds >= kMapMovedSeconds;
  char run[96];
  std::snprintf(run, sizeof run, "%d key frames over %.1f s", refused_in_a_row_, run_seconds);
  // Nothing contradicted SLAM, and what it says holds together for a while:
  // SLAM went on where neither the last key frame nor the place can check
  // (after tracking was lost, or into new rooms). Learning stays with it.
  if (persisted && !run_refuted_) {
    follow(std::move(seen));
    why.clear();
    return true;
  }
  if (!persisted || run_told_ || !reference_) {
    candidate_ = std::move(seen);
    std::lock_guard<std::mutex> lock(status_mutex_);
    ++status_.refused;
    status_.last_refusal = why;
    return false;
  }
  // SLAM's map moved under the place: what it says now holds together, the
  // place contradicts it. Never taught to the place; a new place, if the
  // learner can start one, learns it from this key frame on.
  run_told_ = true;
  const bool apart = new_place && new_place();
  std::string moved_why =
      std::string("SLAM's map moved: ") + run +
      " agree with one another but not with the learned place; SLAM now puts the camera at " +
      position(seen.pose) + ", " + describe(poseDifference(reference_->pose, seen.pose)) +
      " from the last learned key frame at " + position(reference_->pose) +
      (apart ? " (a map reset, or a room that looks like a learned one?). What follows is "
               "learned as a new place beside the old one, in the same map frame; where both fit "
               "a frame alike but disagree, it has no pose"
             : " (a map reset?). Learning into this place is stopped until SLAM's poses agree "
               "with it again; learn the new map as a new place (restart learning)");
  std::lock_guard<std::mutex> lock(status_mutex_);
  ++status_.map_moves;
  status_.map_moved_why = std::move(moved_why);
  if (apart) {
    ++status_.new_places;
    follow(std::move(seen));
    why.clear();
    return false;
  }
  candidate_ = std::move(seen);
  ++status_.refused;
  status_.last_refusal = why;
  status_.map_moved = true;
  return false;
}

SlamCheckStatus SlamPoseCheck::status() const {
  std::lock_guard<std::mutex> lock(status_mutex_);
  return status_;
}

}  // namespace relocalizer
