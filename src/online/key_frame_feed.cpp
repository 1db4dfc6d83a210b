#include "relocalizer/online/key_frame_feed.h"

#include <chrono>

namespace relocalizer {

KeyFrameFeed::KeyFrameFeed(Learner& learner, const LearningParams& params)
    : learner_(learner), selector_(params.min_motion), check_(params.slam_check) {}

KeyFrameFeed::Result KeyFrameFeed::offer(const std::optional<Pose>& camera_to_world,
                                         const std::function<Expected<RgbdFrame>()>& load) {
  using Outcome = Result::Outcome;
  if (!camera_to_world) return {Outcome::Untracked, {}, 0.0, {}};
  if (std::string why = slamPoseError(*camera_to_world); !why.empty())
    return {Outcome::Untracked, std::move(why), 0.0, {}};
  if (!selector_.due(*camera_to_world)) return {Outcome::NotKeyFrame, {}, 0.0, {}};
  auto frame = load();
  if (!frame) return {Outcome::Failed, frame.error(), 0.0, {}};
  // Built when asked: the check asks only when the images cannot tell.
  const SlamPoseCheck::AskPlace answer = [this](const RgbdFrame& seen) -> std::optional<Pose> {
    PlaceSet places;
    if (!putLearned(learner_.currentPlaces(), places)) return std::nullopt;
    const Relocalization r = places.relocalize(seen).relocalization;
    if (!r.success) return std::nullopt;
    return r.pose;
  };
  const SlamPoseCheck::StartNewPlace new_place = [this] { return learner_.startNewPlace(); };
  const std::string refused = check_.check(*frame, *camera_to_world, answer, new_place);
  std::string moved;
  if (const SlamCheckStatus status = check_.status(); status.map_moves != map_moves_) {
    map_moves_ = status.map_moves;
    moved = status.map_moved_why;
  }
  if (!refused.empty())
    return {Outcome::Refused, "key frame " + std::to_string(frame->id) + ": " + refused, 0.0,
            std::move(moved)};
  selector_.take(*camera_to_world);
  const auto start = std::chrono::steady_clock::now();
  auto added = learner_.addKeyFrame(*frame, *camera_to_world);
  if (!added) return {Outcome::Failed, added.error(), 0.0, std::move(moved)};
  return {*added == KeyFrameAdded::Stored ? Outcome::Learned : Outcome::Covered,
          {},
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
          std::move(moved)};
}

}  // namespace relocalizer
