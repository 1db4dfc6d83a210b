#include "relocalizer/relocalize/light_retry.h"

#include <algorithm>
#include <cmath>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

std::optional<LightRebalance> rebalanceIntoTrainingLight(const cv::Mat& bgr, const Model& model,
                                                         float min_cast) {
  const Eigen::Vector3f& trained = model.summary.light_chromaticity;
  if (!(min_cast > 0.0f) || model.params.colour_normalisation != ColourNormalisation::kNone ||
      !(trained.minCoeff() > 0.0f))
    return std::nullopt;
  const cv::Vec3d seen = lightChromaticity(bgr);
  LightRebalance rebalance;
  for (int c = 0; c < 3; ++c) {
    if (!(seen[c] > 0.0)) return std::nullopt;
    rebalance.gains[c] = trained[c] / seen[c];
    rebalance.cast = std::max(rebalance.cast, std::abs(std::log(rebalance.gains[c])));
  }
  if (rebalance.cast < min_cast) return std::nullopt;
  return rebalance;
}

namespace {

// The frame with its colour rebalanced; depth and pose as they were.
RgbdFrame inTrainingLight(const RgbdFrame& frame, const LightRebalance& rebalance) {
  RgbdFrame rebalanced = frame;
  rebalanced.colour = applyChannelGains(frame.colour, rebalance.gains);
  return rebalanced;
}

}  // namespace

PlaceAnswer searchedAgainInTrainingLight(const std::vector<std::shared_ptr<const Place>>& places,
                                         const RgbdFrame& frame, const PoseHint* hint,
                                         const PlaceSearchParams& params, PlaceAnswer first) {
  if (first.relocalization.success || places.size() < 2 || first.attempts.empty()) return first;
  for (const PlaceAttempt& attempt : first.attempts)
    if (attempt.success) return first;  // ambiguous
  const auto best = std::find_if(places.begin(), places.end(), [&](const auto& place) {
    return place->name == first.attempts.front().place;
  });
  if (best == places.end()) return first;
  const Relocalizer& screened_best = *(*best)->relocalizer;
  const std::optional<LightRebalance> rebalance = rebalanceIntoTrainingLight(
      frame.colour, screened_best.model(), screened_best.params().light_retry_min_cast);
  if (!rebalance) return first;
  PlaceAnswer second = searchPlaces(places, inTrainingLight(frame, *rebalance), hint, params);
  float& cast = second.relocalization.light_cast;
  cast = std::max(cast, static_cast<float>(rebalance->cast));
  second.relocalization.timings.total += first.relocalization.timings.total;
  if (second.relocalization.success) return second;
  first.relocalization.message +=
      "; searched again in the light of " + (*best)->name + ": " + second.relocalization.message;
  first.relocalization.light_cast = cast;
  first.relocalization.timings.total = second.relocalization.timings.total;
  return first;
}

Relocalization askedAgainInTrainingLight(
    const RgbdFrame& frame, Relocalization first, const Model& model, float min_cast,
    const std::function<Relocalization(const RgbdFrame&)>& ask) {
  const std::optional<LightRebalance> rebalance =
      rebalanceIntoTrainingLight(frame.colour, model, min_cast);
  if (!rebalance) return first;
  Relocalization second = ask(inTrainingLight(frame, *rebalance));
  second.light_cast = static_cast<float>(rebalance->cast);
  second.timings.total += first.timings.total;
  if (!second.success)
    second.message = first.message + "; in the training light too: " + second.message;
  return second;
}

}  // namespace relocalizer
