#pragma once
// Many places, one answer: a set of named models (rooms, floors, submaps), each
// with the frame its world coordinates are in, and relocalization against the
// whole set that says which place the frame is in.
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
// solved at all (it could only agree, at the cost of a full solve).

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

struct Place {
  std::string name;       // unique within a set; what answers and logs say
  std::string map_frame;  // the frame the model's world coordinates are in
  std::string source;     // where the model came from (its path), for listings
  std::shared_ptr<const Relocalizer> relocalizer;
  // Places of one group are parts of one map (submaps): one map frame, and
  // answers that agree are one answer, not rivals. Empty: a place on its own.
  // A shared map_frame alone does not make one map: two models a user loads
  // into one frame stay rivals, as they were before groups.
  std::string group;
  // The model file's identity (modelFileIdentity), as PlaceSet::load or a
  // folder's loader (place_files.h) read it; empty for a model that is no
  // file's (built in memory, learned).
  std::string model_id;
};

// A model file's identity for Place::model_id, from its contents (CRC-32 and
// size), so that a copy, a link or another spelling of the path is the same
// model; empty when it cannot be read (then nothing is compared).
std::string modelFileIdentity(const std::string& path);
// The same from a file's CRC-32 and size known already (a learned submap's
// file as it was written).
std::string modelIdentity(uint32_t crc32, uint64_t bytes);

// What a listing shows of a place.
struct PlaceFigures {
  std::string name;
  std::string map_frame;
  std::string source;
  std::string group;
  int point_trees = 0;
  int line_trees = 0;
  long modes = 0;            // leaf modes over both forests
  long surface_voxels = 0;   // the scene surface's voxels (0: none)
  long training_frames = 0;  // frames the model was trained on
  uint64_t model_bytes = 0;  // forests and surface in memory
};

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
  // Two answers of one group agree within these (core/pose.h's errors): two
  // right answers are each within ~5 cm / 5 deg of the truth, so of each other
  // within about twice that.
  double agreement_metres = 0.10;
  double agreement_degrees = 10.0;
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

// Names are one namespace. A group's name, and every name under it
// (`group/...`), is the group's: a place on its own may not take it, and a
// group may not be named after a place on its own nor take names under one's
// name. A place on its own replaces only a place on its own of its name.
// One model file twice in one map frame is refused (unless both are places
// of one group): the two would explain every frame alike, so every frame
// would be "ambiguous place" (issue 38, D1 and D3).
class PlaceSet {
 public:
  explicit PlaceSet(PlaceSearchParams params = {});

  // Loads a model file as a place, with its model_id. The error names the
  // place and the file.
  static Expected<Place> load(const std::string& name, const std::string& model_path,
                              const std::string& map_frame, const RelocalizerParams& params);

  // Adds a place, or replaces the one of the same name (a retrained model).
  // Refuses an empty name or frame, a model the parameters cannot use, a
  // group place in another frame than its group's, a name the namespace rules
  // above give to another, or a model file another place holds in that frame.
  Status put(Place place);
  // Makes `places` the group's places, all at once (a relocalization sees the
  // group before or after, never half): each gets `group`; the group's places
  // not among them go; one of the same name is replaced in its position.
  // Refuses (and changes nothing) an empty group, what put() refuses, two
  // places of one name or of two frames, a name held outside the group, a
  // group named after a place on its own (or over names under its name), or
  // a model file a place outside the group holds in that frame.
  Status putGroup(const std::string& group, std::vector<Place> places);
  // Removes the place of that name, or else every place of the group of that
  // name (a saved set of submaps goes as it came). False when neither is there.
  bool remove(const std::string& name);
  std::vector<PlaceFigures> list() const;
  std::vector<std::string> names() const;
  size_t size() const;
  // The places now, in the order they were added (shared: a later put or
  // remove does not change them).
  std::vector<std::shared_ptr<const Place>> places() const { return snapshot(); }

  // Thread-safe, also against put/remove from other threads: a call works on
  // the places as they were when it started. A `hint` (pose_hint.h) reaches
  // only the places whose map frame is hint->frame: their screens rank and
  // their answers weigh against a rival place by the hint's factor (at most
  // 1 + hint_weight), as hypotheses do inside one place.
  PlaceAnswer relocalize(const RgbdFrame& frame, const PoseHint* hint = nullptr) const;

  const PlaceSearchParams& params() const { return params_; }

 private:
  std::vector<std::shared_ptr<const Place>> snapshot() const;

  PlaceSearchParams params_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<const Place>> places_;  // in the order they were added
};

PlaceFigures placeFigures(const Place& place);

}  // namespace relocalizer
