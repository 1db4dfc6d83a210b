#include "relocalizer/relocalize/light_retry.h"

#include <algorithm>
#include <cmath>

#include "relocalizer/core/photometric_change.h"

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

}  // namespace relocalizer
