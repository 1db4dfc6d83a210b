#pragma once
// The place search: one frame relocalized against many places (place.h),
// with one answer that says which place the frame is in.
//
// Asking every place for a full relocalization would cost N times one answer.
// Instead the frame is sampled once (samples and descriptors do not depend on
// the model), every place is screened by a cheap pass (a few hundred of the
// samples through its point forest and a short Kabsch-only RANSAC; its best
// hypothesis' inlier count ranks the place; a first look at every place, the
// full screen only where it comes close), and only the best-ranked places
// get the full solve. A runner-up whose screen comes close to the best is
// solved too (beside it, on the other threads), and when two places both hold
// up the answer is "no pose": naming the wrong room would be worse than
// naming none.
//
// Unless they are one map: places of one group (the submaps of a map, in its
// one frame) whose answers agree give one answer, that pose; and a runner-up
// of the group whose screen already agrees with a place that answered is not
// solved at all (it could only agree, at the cost of a full solve). When the
// best screened place fails, the other places of its map are asked however
// weakly they screened (they cannot answer in a wrong frame), those left at
// the first look screened fully first, best screened first. A map in parts
// (Place::part: SLAM's map moved under the older) is one map with a caveat:
// an older part's answer stands only where no newer part, asked too, disagrees.

#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/pose/pose_hint.h"
#include "relocalizer/relocalize/place.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

struct PlaceSearchParams {
  // The screen that ranks places (relocalizer.h), in two passes: a first look
  // at every place, on fewer samples with a short draw, then `screen` for the
  // places whose first look (inliers, weighed by the hint) reaches
  // rescreen_ratio of the best's; the first look's predictions are reused, so
  // those places screen exactly as with `screen` alone. The full budget costs
  // most on the places a frame is not in (their draws find few rigid sets),
  // which the first look leaves out. A best first look under
  // rescreen_all_below inliers (a frame hard to screen, where the right place
  // may look no better than the rest) gets `screen` on every place.
  // first_look.samples 0: every place gets `screen`, as before the first look.
  // 50 samples and 5 inliers (a quarter of `screen`'s samples and half the
  // first look's 100 and 10 before) answer the 6-room walk's 300 test frames
  // exactly as before (poses cmp-identical, 21 learned submaps) at 1.4 ms
  // less a call on one thread, 0.4 ms on two; 40 and 4, or 50 and 4, lose a frame
  // (docs/online_learning.md, "A first look on 50 samples").
  ScreenParams screen;
  ScreenParams first_look{50, 32, 20, 1};
  float rescreen_ratio = 0.25f;
  int rescreen_all_below = 5;
  // Full solves per frame at most (the best and close runners-up); a group
  // runner-up left unsolved for its screen pose does not count.
  int max_solved = 3;
  // The runner-up is solved too when its screen inliers reach this share of the best's.
  float runner_up_ratio = 0.5f;
  // Two places that both answer: the weaker one is no rival below this share
  // of the stronger's inliers; at or above it the frame is ambiguous.
  float ambiguity_ratio = 0.8f;
  // Two answers of one group agree within these (core/pose.h's posesAgree).
  double agreement_metres = kAnswersAgreeMetres;
  double agreement_degrees = kAnswersAgreeDegrees;
  // A runner-up of the group whose screen pose is within these of the screen
  // pose of a place that answered is not solved; negative: every close
  // runner-up is solved. Coarse, as screens are (Kabsch on 200 samples), yet
  // twice the screen's worst error: rk.model on the 200 redkitchen-dev test
  // frames screens at 2.2 cm / 0.8 deg from the truth (median), 8.0 cm / 3.6
  // deg (p95), every frame within 0.15 m / 7.5 deg.
  double screen_agreement_metres = 0.3;
  double screen_agreement_degrees = 15.0;

  std::string validationError() const;  // empty when usable
};

// How one place fared with one frame.
struct PlaceAttempt {
  std::string place;
  // The screen's best hypothesis: the full screen's, or (screened_fully
  // false) the first look's, on fewer samples; fully screened places rank first.
  int screen_inliers = 0;
  bool solved = false;   // the full solve ran
  bool success = false;  // and answered with a pose
  std::string message;   // its reason when it ran and failed
  // Same group as the strongest answer and the same pose (solved), or not
  // solved because its screen pose agreed with that answer's place's: not a
  // rival. The strongest answer is the answer unless the frame is ambiguous.
  bool agrees = false;
  bool screened_fully = true;  // see screen_inliers
};

// Where a search across two or more places spent its time (one place alone
// is a plain relocalization: its stages are in relocalization.timings).
struct PlaceSearchTimings {  // seconds
  double sampling = 0.0;     // the frame's shared samples and descriptors
  double screening = 0.0;    // every place's screen (= relocalization.timings.screening)
  int full_screens = 0;      // places that got the full screen after the first look
  double solving = 0.0;      // the full solves, wall time
  int solves = 0;            // full solves run
  // The full solves' own stages, summed over them (forest: both forests on the
  // shared samples; ransac, refinement, surface as in StageTimings).
  double forest = 0.0, ransac = 0.0, refinement = 0.0, surface = 0.0;
};

struct PlaceAnswer {
  std::string place;                   // the answering place; empty for "no pose"
  std::string map_frame;               // its frame; empty for "no pose"
  Relocalization relocalization;       // pose in map_frame, or the failure and its reason
  std::vector<PlaceAttempt> attempts;  // every place, best screened first
  PlaceSearchTimings search;           // zero for one place
};

// Searches `places` for the frame (the rules atop this header). A `hint`
// (pose_hint.h) reaches only the places whose map frame is hint->frame: their
// screens rank and their answers weigh against a rival place by the hint's
// factor (at most 1 + hint_weight), as hypotheses do inside one place. No
// places: "no place is loaded"; one place: its own relocalization, nothing to
// rank.
PlaceAnswer searchPlaces(const std::vector<std::shared_ptr<const Place>>& places,
                         const RgbdFrame& frame, const PoseHint* hint,
                         const PlaceSearchParams& params);

}  // namespace relocalizer
