#pragma once
// What a learner continuing a saved place starts from (SubmapLearner::resume),
// read from one of three things a user names with `model:=`: a folder of
// submaps (submap_folder.h), a place learned before submaps (one model file
// and its key frames, OnlineLearner::save), or a model made by `train` (one
// model file, no key frames: a surveyed submap, place_change.h).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer {

// A frozen submap as read.
struct ResumedFrozen {
  std::shared_ptr<const Relocalizer> relocalizer;  // null: skipped (a warning says why)
  bool written = false;  // its model and key frames are in the set's folder already
  ModelFileId model_id;  // of that model file, when written
};

struct ResumedSubmaps {
  std::vector<std::vector<SubmapKeyFrame>> key_frames;  // by submap index (SubmapIndex::restore)
  std::vector<ResumedFrozen> frozen;                    // by submap index; the active one empty
  int active_index = -1;                                // -1: none
  std::shared_ptr<OnlineLearner> active;                // null: none
  std::int64_t next_id = 0;                             // the next key frame's id
  std::string folder;  // the set's folder, the working folder from now on; empty for a model file
  std::vector<std::string> warnings;  // submaps skipped, files not used, naming each and why
};

// Reads `path` to be continued with `learning` in `map_frame`: a folder's
// frozen submaps served with learnedModelParams (a survey in it with `params`
// as it is), its active submap a learner in `mode`; a learned model file the
// active submap 0 with its key frames; a model file without key frames the
// frozen, surveyed submap 0 served with `params` (not retrained: it has no key
// frames to be trained on; not yet written into any folder). Fails naming the
// file when a folder has no readable manifest (starting over would overwrite
// the set at the next save) or a model file does not load.
Expected<ResumedSubmaps> readResumedSubmaps(const std::string& path, const LearningParams& learning,
                                            const RelocalizerParams& params,
                                            OnlineLearner::Mode mode, const std::string& map_frame);

}  // namespace relocalizer
