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

Relocalization Relocalizer::askedInTrainingLight(const RgbdFrame& frame, Relocalization first,
                                                 const PoseHint* hint) const {
  if (first.success || !frameRefusal(frame).empty()) return first;
  const std::optional<LightRebalance> rebalance =
      rebalanceIntoTrainingLight(frame.colour, model_, params_.light_retry_min_cast);
  if (!rebalance) return first;
  RgbdFrame rebalanced = frame;
  rebalanced.colour = applyChannelGains(frame.colour, rebalance->gains);
  Relocalization second = relocalizeAsSeen(rebalanced, hint);
  second.light_cast = static_cast<float>(rebalance->cast);
  second.timings.total += first.timings.total;
  if (!second.success)
    second.message = first.message + "; in the training light too: " + second.message;
  return second;
}

}  // namespace relocalizer
