#include "relocalizer/online/key_frame_feed.h"

#include <chrono>

namespace relocalizer {

KeyFrameFeed::KeyFrameFeed(LearningParams params, RelocalizerParams relocalizer_params,
                           OnlineLearner::Mode mode)
    : motion_(params.min_motion),
      selector_(params.min_motion),
      learner_(std::move(params), std::move(relocalizer_params), mode) {}

KeyFrameFeed::Result KeyFrameFeed::offer(const std::optional<Pose>& camera_to_world,
                                         const std::function<Expected<RgbdFrame>()>& load) {
  return offerTo(selector_, camera_to_world, load,
                 [&](const RgbdFrame& frame, const Pose& pose) -> Expected<bool> {
                   if (Status added = learner_.addKeyFrame(frame, pose); !added)
                     return makeError(added.error());
                   return true;
                 });
}

KeyFrameFeed::Result KeyFrameFeed::offerTo(KeyFrameSelector& selector,
                                           const std::optional<Pose>& camera_to_world,
                                           const std::function<Expected<RgbdFrame>()>& load,
                                           const Store& store) {
  using Outcome = Result::Outcome;
  if (!camera_to_world) return {Outcome::Untracked, {}, 0.0};
  if (std::string why = slamPoseError(*camera_to_world); !why.empty())
    return {Outcome::Untracked, std::move(why), 0.0};
  if (!selector.keep(*camera_to_world)) return {Outcome::NotKeyFrame, {}, 0.0};
  auto frame = load();
  if (!frame) return {Outcome::Failed, frame.error(), 0.0};
  const auto start = std::chrono::steady_clock::now();
  auto stored = store(*frame, *camera_to_world);
  if (!stored) return {Outcome::Failed, stored.error(), 0.0};
  return {*stored ? Outcome::Learned : Outcome::Covered,
          {},
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
}

}  // namespace relocalizer
