#pragma once
// What the learning loop (key_frame_feed.h) needs of a learner, whichever it
// is: one capped store (online_learner.h) or submaps (submap_learner.h). The
// node, `evaluate --learn-frames` (with and without --submaps) and
// `learn_benchmark` drive either through this one interface, so the loop is
// written once.

#include <cstddef>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/relocalize/place_set.h"

namespace relocalizer {

// What a learner's places are called: one group `place` in `map_frame`
// (submaps: `<place>/<index>`; one store: `place`).
struct LearnerNames {
  std::string place = "learned";
  std::string map_frame = "map";
};

// What became of a key frame a learner accepted.
enum class KeyFrameAdded {
  Stored,   // kept; learned at the next retrain
  Covered,  // not kept: what is learned already holds one as good (submaps)
};

// The figures every learner has, for the loop's reports (each learner's own
// status() has the rest).
struct LearnerSummary {
  int keyframes_added = 0;    // stored since start, resumed ones included
  int keyframes_learned = 0;  // of them, known to a model now
  int backlog = 0;            // added to the model still learning, not in it yet
  std::string last_error;     // of the last failed retrain, freeze or save; empty if none
};

class Learner {
 public:
  virtual ~Learner() = default;

  // A key frame the feed chose, with SLAM's camera-to-world pose, which the
  // feed has checked (slamPoseError, slam_pose_check.h): stored or covered,
  // or why it could not be.
  virtual Expected<KeyFrameAdded> addKeyFrame(const RgbdFrame& frame,
                                              const Pose& camera_to_world) = 0;
  // Blocks until every model is trained on all its key frames.
  virtual Status drain() = 0;
  // The learned models now, as the places of one group in one map frame
  // (Place::group set; for PlaceSet::putGroup); empty before the first model.
  virtual std::vector<Place> places() const = 0;
  // SLAM's map moved under what is learned (slam_pose_check.h: a reset, or a
  // look-alike room the place mistakes for one it knows): what follows is
  // learned as a new place in the same map frame, sharing no key frame or
  // model with what was learned before, whose answers stay (where both fit a
  // frame alike but disagree, it has no pose). False when the learner holds one model
  // (one store): learning into it then stops.
  virtual bool startNewPlace() { return false; }
  // The places learned since the last startNewPlace() (all, before one): the
  // ones the SLAM check asks.
  virtual std::vector<Place> currentPlaces() const { return places(); }
  // Writes what is learned to `path` (a model file, or a folder of submaps).
  virtual Status save(const std::string& path) = 0;
  virtual LearnerSummary summary() const = 0;
};

// A learner's places() as their group of `places`, all at once (none:
// nothing is put); fails when putGroup refuses them.
Status putLearned(std::vector<Place> learned, PlaceSet& places);

}  // namespace relocalizer
