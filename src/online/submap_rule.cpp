#include "relocalizer/online/submap_rule.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "relocalizer/core/key_frame_rule.h"

namespace relocalizer {

std::string submapParamsError(const SubmapParams& p, int max_keyframes, const SettingName& name) {
  const auto n = [&](const std::string& field) { return settingName(name, field); };
  if (max_keyframes < 2)
    return n("max_keyframes") + " must be at least 2 (got " + std::to_string(max_keyframes) + ")";
  if (!(p.area_radius > 0.0 && std::isfinite(p.area_radius)))
    return n("area_radius") + " must be a finite distance > 0 metres (got " +
           std::to_string(p.area_radius) + ")";
  // A new submap must have room for its seeds and the key frame that started it.
  if (p.overlap < 0 || p.overlap >= max_keyframes)
    return n("overlap") + " must be between 0 and " + n("max_keyframes") + " - 1 (got " +
           std::to_string(p.overlap) + ")";
  if (!(p.cover_steps >= 0.0 && std::isfinite(p.cover_steps)))
    return n("cover_steps") + " must be finite and >= 0 (got " + std::to_string(p.cover_steps) +
           ")";
  if (!(p.relearn_agreement >= 0.0 && p.relearn_agreement <= 1.0))
    return n("relearn_agreement") + " must be a share between 0 and 1 (got " +
           std::to_string(p.relearn_agreement) + ")";
  if (p.min_submap_keyframes < 0 || p.min_submap_keyframes > max_keyframes)
    return n("min_submap_keyframes") + " must be between 0 and " + n("max_keyframes") + " (got " +
           std::to_string(p.min_submap_keyframes) + ")";
  return {};
}

SubmapIndex::SubmapIndex(SubmapParams params, int max_keyframes)
    : params_(params), max_keyframes_(max_keyframes) {
  if (const std::string why = submapParamsError(params_, max_keyframes_); !why.empty())
    throw std::invalid_argument(why);
}

int SubmapIndex::minSubmapKeyFrames() const {
  return params_.min_submap_keyframes > 0 ? params_.min_submap_keyframes
                                          : std::max(1, max_keyframes_ / 4);
}

const std::vector<SubmapKeyFrame>& SubmapIndex::keyFrames(int submap) const {
  return submaps_.at(static_cast<std::size_t>(submap));
}

bool SubmapIndex::inActiveArea(const Pose& pose) const {
  const auto& frames = keyFrames(active_);
  return std::any_of(frames.begin(), frames.end(), [&](const SubmapKeyFrame& k) {
    return translationError(k.pose, pose) <= params_.area_radius;
  });
}

bool SubmapIndex::holdsNear(int submap, const Pose& pose) const {
  if (params_.cover_steps <= 0.0) return false;
  const std::vector<SubmapKeyFrame>& frames = keyFrames(submap);
  return std::any_of(frames.begin(), frames.end(), [&](const SubmapKeyFrame& k) {
    return keyFrameDistance(k.pose, pose) < params_.cover_steps;
  });
}

std::vector<int> SubmapIndex::coveringSubmaps(const Pose& pose) const {
  std::vector<int> covering;
  for (int s = first_of_place_; s < submapCount(); ++s)
    // Frozen ones only, so that a run that fits one submap learns as one store does.
    if (frozen(s) && holdsNear(s, pose)) covering.push_back(s);
  return covering;
}

std::vector<int> SubmapIndex::surveyedSubmaps() const {
  std::vector<int> surveyed;
  for (int s = first_of_place_; s < submapCount(); ++s)
    if (frozen(s) && keyFrames(s).empty()) surveyed.push_back(s);
  return surveyed;
}

SubmapDecision SubmapIndex::decide(const Pose& pose, bool may_cover) const {
  if (may_cover && !coveringSubmaps(pose).empty()) return SubmapDecision::Covered;
  if (active_ < 0) return SubmapDecision::Start;
  if (active_ < first_of_place_) return SubmapDecision::NewLeft;  // of the map SLAM left
  // A view of a changed place that the active submap already holds is being
  // learned again there: a camera that loops past it would otherwise relearn
  // it on every lap (only frozen submaps cover, and until the active one
  // freezes, the old ones still disagree there).
  if (!may_cover && holdsNear(active_, pose)) return SubmapDecision::Covered;
  const int held = static_cast<int>(keyFrames(active_).size());
  // Before the cap: a camera that left starts afresh rather than with seeds
  // from an area it is no longer in.
  if (held >= minSubmapKeyFrames() && !inActiveArea(pose)) return SubmapDecision::NewLeft;
  if (held >= max_keyframes_) return SubmapDecision::NewFull;
  return SubmapDecision::Active;
}

std::vector<SubmapKeyFrame> SubmapIndex::nearestOfActive(const Pose& pose, int count) const {
  std::vector<SubmapKeyFrame> frames = keyFrames(active_);
  count = std::min(count, static_cast<int>(frames.size()));
  // Stable, so equally near key frames keep their order and runs repeat exactly.
  std::stable_sort(frames.begin(), frames.end(),
                   [&](const SubmapKeyFrame& a, const SubmapKeyFrame& b) {
                     return keyFrameDistance(a.pose, pose) < keyFrameDistance(b.pose, pose);
                   });
  frames.resize(static_cast<std::size_t>(count));
  return frames;
}

SubmapPlacement SubmapIndex::place(std::int64_t id, const Pose& pose, bool may_cover) {
  SubmapPlacement placement;
  placement.decision = decide(pose, may_cover);
  switch (placement.decision) {
    case SubmapDecision::Covered:
      return placement;
    case SubmapDecision::Active:
      break;
    case SubmapDecision::NewFull:
      placement.seeds = nearestOfActive(pose, params_.overlap);
      [[fallthrough]];
    case SubmapDecision::Start:
    case SubmapDecision::NewLeft:
      submaps_.push_back(placement.seeds);
      active_ = submapCount() - 1;
      break;
  }
  submaps_[static_cast<std::size_t>(active_)].push_back({id, pose});
  placement.submap = active_;
  return placement;
}

void SubmapIndex::freezeActive() { active_ = -1; }

void SubmapIndex::startApart() { first_of_place_ = submapCount(); }

void SubmapIndex::restore(std::vector<std::vector<SubmapKeyFrame>> submaps, int active) {
  if (!submaps_.empty())
    throw std::invalid_argument("a submap index is restored before its first key frame");
  if (active < -1 || active >= static_cast<int>(submaps.size()))
    throw std::invalid_argument("restored active submap " + std::to_string(active) +
                                " is not one of the " + std::to_string(submaps.size()));
  submaps_ = std::move(submaps);
  active_ = active;
}

}  // namespace relocalizer
