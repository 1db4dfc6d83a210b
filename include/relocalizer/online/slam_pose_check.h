#pragma once
// The one place a SLAM pose is judged before learn mode learns from it
// (issue 38, D2). A learned place is only as right as the poses it was taught:
// SLAM (or whatever publishes its TF) that jumps metres for a few frames, or
// resets its map to the origin mid-walk, teaches the place two maps at once,
// and the place then answers metres wrong while reporting success. So a key
// frame is learned only when what its images show agrees with the motion SLAM
// claims since the last learned key frame:
//  1. the pose itself is usable (slamPoseError: finite, a rotation, not
//     absurdly far);
//  2. the claimed motion is within a speed bound between the two stamps;
//  3. the depth images, aligned from the claimed motion (frame_alignment.h),
//     show the same motion within a tolerance; when they cannot tell (no
//     overlap, a featureless wall), the learned place's own answer for the
//     frame must agree with SLAM's pose instead.
// Anything else is refused and counted. Refused key frames that agree with
// one another, for a second and kMapMovedKeyFrames in a row, are either SLAM
// going on where nothing can check it (tracking regained elsewhere, new
// rooms: nothing contradicted it, and learning follows it again) or, when
// the speed bound, the depth or the place contradicted them, SLAM's map
// having moved under the place (a reset, a jump that stays, or a look-alike
// room the place takes for one it knows: from one run of frames these look
// the same). The place is never taught the new map: the learner starts a new
// place for it when it can (submaps; the old and the new answer side by
// side, and where both fit a frame alike but disagree it has no pose), and otherwise learning
// stays stopped, said loudly in the status, until SLAM's poses agree with the
// place again.

#include <functional>
#include <mutex>
#include <optional>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/frame_alignment.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/online/setting_name.h"

namespace relocalizer {

// Farthest a SLAM camera pose may be from the map origin to be learned from.
// Leaf modes store world coordinates as float, whose spacing reaches 1 mm at
// 8 km: beyond 10 km a learned place would lose the centimetre accuracy the
// method is judged by, and no room-scale SLAM map is that large, so such a
// pose is a SLAM or TF fault (1e30 m was seen learned and answered).
constexpr double kMaxSlamPoseDistance = 1e4;

// Empty when a camera-to-world pose may be learned from: finite, a rotation
// (orthonormal, det +1) and within kMaxSlamPoseDistance; otherwise why not.
std::string slamPoseError(const Pose& camera_to_world);

// Refused key frames in a row, each agreeing with the one before, over at
// least kMapMovedSeconds, after which SLAM's map is taken to have moved
// (SlamCheckStatus::map_moved): TF that jumps for a fraction of a second
// stays below it, a map reset reaches it a second after.
constexpr int kMapMovedKeyFrames = 5;
constexpr double kMapMovedSeconds = 1.0;

struct SlamCheckParams {
  bool enabled = true;  // false: only slamPoseError (what learning did before issue 38)
  // Fastest camera SLAM may claim between two key frames: a handheld camera
  // or a robot stays far below it; a 2 m jump between two 30 Hz frames is
  // 60 m/s.
  double max_speed = 3.0;   // metres per second
  double max_turn = 360.0;  // degrees per second
  // How far the motion the depth images show may be from SLAM's. ICP from a
  // right claim lands within millimetres; the tolerance leaves room for the
  // reference trajectories of datasets (7-Scenes jumps 3.6 cm / 1.4 deg once
  // in redkitchen) and refuses what would teach the place centimetres off.
  double max_disagreement_metres = 0.05;
  double max_disagreement_degrees = 5.0;
};

// Empty when usable, otherwise what is wrong, naming the setting
// (max_slam_speed, slam_disagreement).
std::string slamCheckParamsError(const SlamCheckParams& params, const SettingName& name = {});

// The bounds as text: `speed` "3,360" (metres, degrees per second) and
// `disagreement` "0.05,5" (metres, degrees) into `params`; the error quotes
// the text and names the setting.
Status readSlamCheckBounds(const std::string& speed, const std::string& disagreement,
                           SlamCheckParams& params, const SettingName& name = {});

// What the check did since start.
struct SlamCheckStatus {
  int checked = 0;         // key frames judged against a reference
  int refused = 0;         // of them refused: SLAM's motion disagreed with the images or the place
  int runs_learned = 0;    // key frames learned unconfirmed: SLAM went on where nothing could
                           // check it, consistently for kMapMovedKeyFrames and a second, and
                           // nothing contradicted it (tracking regained, new rooms)
  int map_moves = 0;       // times refused key frames persisted (kMapMovedKeyFrames) into a new map
  int new_places = 0;      // of them, learned on as a new place
  bool map_moved = false;  // now: learning stopped until SLAM's poses agree with the place again
  std::string last_refusal;    // why the last refused key frame was refused
  std::string map_moved_why;   // the last map move, loudly: what moved and what learning does
  double check_seconds = 0.0;  // wall time of all checks (depth alignments, place answers)
};

class SlamPoseCheck {
 public:
  explicit SlamPoseCheck(SlamCheckParams params = {});

  // The learned place's answer for a frame, in the map frame (nullopt: no
  // pose, or no place yet).
  using AskPlace = std::function<std::optional<Pose>(const RgbdFrame& frame)>;
  // Starts a new place for what follows SLAM's map move (Learner::startNewPlace);
  // false: it cannot, and learning stops.
  using StartNewPlace = std::function<bool()>;

  // Empty when `frame` (a key frame by the rule, SLAM's `camera_to_world`,
  // which slamPoseError passed, frame.stamp in seconds) may be learned from; it then becomes the
  // reference the next key frame is checked against. Otherwise why not (also
  // in status().last_refusal). Without a reference (the first key frame)
  // only the place's answer, if any, is checked. The key frame that shows
  // SLAM's map moved is learned, as the first of a new place, when
  // `new_place` starts one.
  std::string check(const RgbdFrame& frame, const Pose& camera_to_world,
                    const AskPlace& answer = {}, const StartNewPlace& new_place = {});

  // Thread-safe: the node's status is read on other threads.
  SlamCheckStatus status() const;
  const SlamCheckParams& params() const { return params_; }

 private:
  struct Seen {
    Pose pose;
    double stamp = 0.0;
    cv::Mat depth;
    CameraIntrinsics camera;
  };
  struct Verdict {
    enum Outcome { Confirmed, Refuted, Unconfirmed } outcome;
    std::string why;  // unless Confirmed
  };
  // What the depth images say of the motion SLAM claims from `from` to `to`.
  Verdict depthVerdict(const Seen& from, const Seen& to) const;
  Verdict judge(const Seen& seen, const RgbdFrame& frame, const AskPlace& answer) const;
  // A key frame not confirmed: refused (false, `why` kept), or learned after
  // all (true, `why` cleared) when it ends a run nothing contradicted, or
  // one that `new_place` learns apart.
  bool refused(Seen seen, const Verdict& verdict, const StartNewPlace& new_place, std::string& why);
  // `seen` is the reference from now on; no refused run is pending.
  void follow(Seen seen);

  const SlamCheckParams params_;
  std::optional<Seen> reference_;  // the last learned key frame
  std::optional<Seen> candidate_;  // the last refused one
  int refused_in_a_row_ = 0;       // refused, each agreeing with the one before
  double run_start_ = 0.0;         // stamp of the first of them
  bool run_told_ = false;          // their run was reported as a map move
  bool run_refuted_ = false;       // something contradicted SLAM in their run
  mutable std::mutex status_mutex_;
  SlamCheckStatus status_;
};

}  // namespace relocalizer
