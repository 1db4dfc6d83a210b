#include "relocalizer/online/key_frame_feed.h"

#include <chrono>

namespace relocalizer {

KeyFrameFeed::KeyFrameFeed(LearningParams params, RelocalizerParams relocalizer_params,
                           OnlineLearner::Mode mode)
    : motion_(params.min_motion),
      track_(params),
      learner_(std::move(params), std::move(relocalizer_params), mode) {}

KeyFrameFeed::Result KeyFrameFeed::offer(const std::optional<Pose>& camera_to_world,
                                         const std::function<Expected<RgbdFrame>()>& load) {
  const std::shared_ptr<const Relocalizer> place = learner_.current();
  SlamPoseCheck::AskPlace answer;
  if (place)
    answer = [&place](const RgbdFrame& frame) -> std::optional<Pose> {
      const Relocalization r = place->relocalize(frame);
      if (!r.success) return std::nullopt;
      return r.pose;
    };
  return offerTo(
      track_, camera_to_world, load,
      [&](const RgbdFrame& frame, const Pose& pose) -> Expected<bool> {
        if (Status added = learner_.addKeyFrame(frame, pose); !added)
          return makeError(added.error());
        return true;
      },
      answer);
}

KeyFrameFeed::Result KeyFrameFeed::offerTo(FeedTrack& track,
                                           const std::optional<Pose>& camera_to_world,
                                           const std::function<Expected<RgbdFrame>()>& load,
                                           const Store& store,
                                           const SlamPoseCheck::AskPlace& answer) {
  using Outcome = Result::Outcome;
  if (!camera_to_world) return {Outcome::Untracked, {}, 0.0};
  if (std::string why = slamPoseError(*camera_to_world); !why.empty())
    return {Outcome::Untracked, std::move(why), 0.0};
  if (!track.selector.due(*camera_to_world)) return {Outcome::NotKeyFrame, {}, 0.0};
  auto frame = load();
  if (!frame) return {Outcome::Failed, frame.error(), 0.0};
  if (std::string why = track.check.check(*frame, *camera_to_world, answer); !why.empty())
    return {Outcome::Refused, "key frame " + std::to_string(frame->id) + ": " + why, 0.0};
  track.selector.take(*camera_to_world);
  const auto start = std::chrono::steady_clock::now();
  auto stored = store(*frame, *camera_to_world);
  if (!stored) return {Outcome::Failed, stored.error(), 0.0};
  return {*stored ? Outcome::Learned : Outcome::Covered,
          {},
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
}

KeyFrameFeed::Store KeyFrameFeed::storeIn(SubmapLearner& submaps) {
  return [&submaps](const RgbdFrame& frame, const Pose& pose) -> Expected<bool> {
    auto placed = submaps.addKeyFrame(frame, pose);
    if (!placed) return makeError(placed.error());
    return placed->decision != SubmapDecision::Covered;
  };
}

}  // namespace relocalizer
