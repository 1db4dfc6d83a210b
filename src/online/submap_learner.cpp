#include "relocalizer/online/submap_learner.h"

#include <stdexcept>

namespace relocalizer {

SubmapLearner::SubmapLearner(LearningParams learning, SubmapParams submaps,
                             RelocalizerParams relocalizer_params)
    : learning_(std::move(learning)),
      relocalizer_params_(std::move(relocalizer_params)),
      index_(submaps, learning_.max_keyframes) {
  if (const std::string why = learningParamsError(learning_); !why.empty())
    throw std::invalid_argument(why);
}

Status SubmapLearner::freezeActive(int frozen) {
  Status drained = active_->drain();
  frozen_.resize(static_cast<std::size_t>(index_.submapCount()));
  frozen_[static_cast<std::size_t>(frozen)] = active_->current();
  active_.reset();
  return drained;
}

Expected<SubmapPlacement> SubmapLearner::addKeyFrame(const RgbdFrame& frame,
                                                     const Pose& camera_to_world) {
  if (const std::string why = slamPoseError(camera_to_world); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  // Checked before the index records it: what the store refuses must not be
  // placed (only an encoder failure is left, which the store reports).
  if (const std::string why = frameValidationError(frame); !why.empty())
    return makeError("key frame " + std::to_string(frame.id) + ": " + why);
  // The index names key frames by arrival, so that the active's store entries
  // (also in arrival order, never evicted: a full submap is replaced, not
  // thinned) line up with its key frames.
  const int was_active = index_.active();
  SubmapPlacement placement = index_.place(next_id_++, camera_to_world);
  if (placement.decision == SubmapDecision::Covered) return placement;
  if (placement.decision != SubmapDecision::Active) {
    std::vector<KeyFrameStore::Entry> seeds;
    if (active_) {
      // A new submap leaves the old one's key frames in the index as they were.
      const std::vector<SubmapKeyFrame>& before = index_.keyFrames(was_active);
      const std::vector<KeyFrameStore::Entry> stored = active_->keyFrames();
      for (const SubmapKeyFrame& seed : placement.seeds)
        for (std::size_t k = 0; k < before.size() && k < stored.size(); ++k)
          if (before[k].id == seed.id) seeds.push_back(stored[k]);
      // A submap that fails its last retrain keeps the model it had: the
      // failure is the caller's to report, the run goes on.
      if (Status frozen = freezeActive(was_active); !frozen) return makeError(frozen.error());
    }
    active_ = std::make_unique<OnlineLearner>(learning_, relocalizer_params_,
                                              OnlineLearner::Mode::Inline);
    if (Status seeded = active_->seed(std::move(seeds)); !seeded) return makeError(seeded.error());
  }
  if (Status added = active_->addKeyFrame(frame, camera_to_world); !added)
    return makeError(added.error());
  return placement;
}

Status SubmapLearner::drain() { return active_ ? active_->drain() : okStatus(); }

std::vector<SubmapModel> SubmapLearner::models() const {
  std::vector<SubmapModel> out;
  for (int s = 0; s < index_.submapCount(); ++s) {
    SubmapModel model;
    model.index = s;
    model.frozen = index_.frozen(s);
    model.keyframes = static_cast<int>(index_.keyFrames(s).size());
    if (model.frozen)
      model.relocalizer = s < static_cast<int>(frozen_.size()) ? frozen_[s] : nullptr;
    else
      model.relocalizer = active_ ? active_->current() : nullptr;
    if (model.relocalizer) out.push_back(std::move(model));
  }
  return out;
}

}  // namespace relocalizer
