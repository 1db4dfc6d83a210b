#pragma once
// Which submap a key frame of a long SLAM run belongs to (issue 26). One store of
// key frames is capped, so a robot that walks a building would thin out its
// first rooms to make room for the last; instead the run is cut into submaps,
// each a capped store of its own, and a full one is frozen (trained one last
// time, written to disk) while a new one grows. The rule sees poses only, no
// images: it runs before a frame is loaded or compressed, and its index (about
// 100 bytes a key frame) stays in memory for submaps long frozen.
//
// Areas are judged by camera centres, not by what the depth sees: no depth is
// needed, and rooms joined by a corridor with no key frames separate cleanly.
// docs/proposals/issue-26-submaps.md has the design and what it measures.

#include <cstdint>
#include <string>
#include <vector>

#include "relocalizer/core/pose.h"
#include "relocalizer/online/setting_name.h"

namespace relocalizer {

struct SubmapParams {
  // The camera is in the active submap's area while its centre is within this
  // many metres of one of the active's key frames.
  double area_radius = 1.5;
  // A submap started because the last was full begins with this many of the
  // last one's key frames nearest to the camera, so each of the two answers
  // alone where they meet.
  int overlap = 4;
  // A key frame this close (key-frame steps, keyFrameDistance) to a key frame
  // of a frozen submap teaches nothing new and is not stored: a robot that
  // loops adds nothing, so disk grows with the area walked, not with time.
  double cover_steps = 1.0;
  // Unless the place changed there: a covered key frame whose depth, at
  // SLAM's pose, lies on the covering frozen submaps' surface (surface_fit.h's
  // agreement) for less than this share is learned again (furniture moved).
  // Measured on the synthetic room of seed 2: 0.985-1.0 where nothing changed,
  // 0.81-0.97 in views of three moved pieces of furniture. 0: never relearn.
  double relearn_agreement = 0.9;
  // A camera that leaves the active's area starts a new submap only once the
  // active holds this many key frames; until then they stay in the active (no
  // slivers from a camera that wanders to and fro at a border). 0: a quarter
  // of the submap cap.
  int min_submap_keyframes = 0;
};

// Empty when `params` are usable with submaps of `max_keyframes`, else what is
// wrong, naming the setting as `name` calls it.
std::string submapParamsError(const SubmapParams& params, int max_keyframes,
                              const SettingName& name = {});

enum class SubmapDecision {
  Start,    // no active submap (the run's first key frame, or the first after a freeze)
  Active,   // joins the active submap
  Covered,  // a frozen submap already holds a key frame as good: not stored
  NewFull,  // the active is full: freeze it, start the next with `overlap` of its key frames
  NewLeft,  // the camera left the active's area: freeze it, start the next afresh
};

struct SubmapKeyFrame {
  std::int64_t id = 0;  // the caller's name for the frame (dataset id, stamp, ...)
  Pose pose = Pose::Identity();
};

// Where one key frame goes.
struct SubmapPlacement {
  SubmapDecision decision = SubmapDecision::Start;
  int submap = -1;  // its submap; -1 when covered (stored nowhere)
  // NewFull: the key frames of the frozen submap that the new one starts with
  // (nearest first), before this one.
  std::vector<SubmapKeyFrame> seeds;
};

// The key-frame poses of every submap of one run, and the rule over them.
class SubmapIndex {
 public:
  // Throws std::invalid_argument when submapParamsError says why.
  SubmapIndex(SubmapParams params, int max_keyframes);

  // Where a key frame at `pose` would go, changing nothing. `may_cover`
  // false: the frozen submaps near it no longer know what the camera sees
  // there (the place changed), so it is learned again as if not covered,
  // unless the active submap holds a key frame as near as cover_steps (it
  // learns that view already).
  SubmapDecision decide(const Pose& pose, bool may_cover = true) const;
  // decide(), then records the key frame (and a new submap with its seeds).
  SubmapPlacement place(std::int64_t id, const Pose& pose, bool may_cover = true);
  // The frozen submaps that would cover a key frame at `pose` (Covered).
  std::vector<int> coveringSubmaps(const Pose& pose) const;
  // The frozen submaps of the place learned now that hold no key-frame poses:
  // a model made by `train` and continued here (SubmapLearner::resume), whose
  // coverage no pose tells but its surface does (place_change.h), or a submap
  // a resume could not load (no model: it covers nothing).
  std::vector<int> surveyedSubmaps() const;
  // The active submap is frozen (a new key frame then starts a new one): what
  // a save at the end of a run does.
  void freezeActive();
  // SLAM's map moved under the submaps so far (Learner::startNewPlace): the
  // next key frame starts a new submap without seeds, and only submaps from
  // it on cover key frames (the old ones' poses are in the map SLAM left).
  void startApart();
  // The first submap of the place learned now: startApart's, else 0.
  int firstOfPlace() const { return first_of_place_; }
  // Takes the submaps of a saved run (by index; an empty one stays empty: a
  // submap that could not be loaded covers nothing) and its active submap (-1:
  // none), so that the run continues as if never stopped. Throws
  // std::invalid_argument after the first place() or for an `active` out of range.
  void restore(std::vector<std::vector<SubmapKeyFrame>> submaps, int active);

  int submapCount() const { return static_cast<int>(submaps_.size()); }
  int active() const { return active_; }  // -1 when none
  bool frozen(int submap) const { return submap != active_; }
  const std::vector<SubmapKeyFrame>& keyFrames(int submap) const;
  // min_submap_keyframes with its 0 resolved against the cap.
  int minSubmapKeyFrames() const;

 private:
  bool inActiveArea(const Pose& pose) const;
  // `submap` holds a key frame within cover_steps of `pose`.
  bool holdsNear(int submap, const Pose& pose) const;
  std::vector<SubmapKeyFrame> nearestOfActive(const Pose& pose, int count) const;

  SubmapParams params_;
  int max_keyframes_;
  std::vector<std::vector<SubmapKeyFrame>> submaps_;
  int active_ = -1;
  int first_of_place_ = 0;
};

}  // namespace relocalizer
