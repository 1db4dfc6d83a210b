#include "relocalizer/relocalize/light_retry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

namespace {

// Cells darker than this are mostly quantisation noise in a ratio, and
// brighter ones may be clipped (linear light, 1 = the sensor's white).
constexpr double kDarkestCell = 2e-3, kBrightestCell = 0.9;
// A view is compared only where at least half of its cells' channels are
// usable in both: fewer say little about a change of light.
constexpr int kMinUsableValues = static_cast<int>(LightGrid().size()) / 2;

// The lights a frame may have been seen in, 10 mired apart (a mired is about
// as far everywhere on the Planckian locus as a person sees it), from about
// 1500 to 14000 K, through the balanced light itself.
struct CandidateLights {
  std::vector<double> kelvins;
  std::vector<cv::Vec3d> ln_gains;
  CandidateLights() {
    const double balanced_mired = 1e6 / PhotometricChange::kBalancedKelvin;
    for (int step = -11; step <= 48; ++step) {
      const double kelvin =
          step == 0 ? PhotometricChange::kBalancedKelvin : 1e6 / (balanced_mired + 10.0 * step);
      const cv::Vec3d gains = whiteBalanceGains(kelvin);
      kelvins.push_back(kelvin);
      ln_gains.emplace_back(std::log(gains[0]), std::log(gains[1]), std::log(gains[2]));
    }
  }
};

bool usable(float light) { return light >= kDarkestCell && light <= kBrightestCell; }

// What a frame's light is matched with: measured once however many models
// it is matched against.
struct SeenLight {
  LightGrid grid;
  cv::Vec3d chromaticity;
  explicit SeenLight(const cv::Mat& bgr)
      : grid(lightGrid(bgr)), chromaticity(lightChromaticity(bgr)) {}
};

LightRebalance withCast(const cv::Vec3d& gains, double mismatch) {
  LightRebalance rebalance;
  rebalance.gains = gains;
  rebalance.mismatch = mismatch;
  for (int c = 0; c < 3; ++c)
    rebalance.cast = std::max(rebalance.cast, std::abs(std::log(gains[c])));
  return rebalance;
}

// The rebalance into `model`'s training light, whatever its size: from the
// nearest training view when the model keeps them, otherwise from the mean
// chromaticity of the training images (with no mismatch known).
std::optional<LightRebalance> rebalanceWithoutGate(const SeenLight& seen, const Model& model) {
  if (model.params.colour_normalisation != ColourNormalisation::kNone) return std::nullopt;
  if (!model.summary.view_lights.empty()) {
    const std::optional<LightChange> change =
        nearestViewLight(seen.grid, model.summary.view_lights);
    if (!change) return std::nullopt;
    const cv::Vec3d lamp = whiteBalanceGains(change->kelvin);
    const double level = std::exp2(-change->stops);
    return withCast(cv::Vec3d(level / lamp[0], level / lamp[1], level / lamp[2]), change->mismatch);
  }
  const Eigen::Vector3f& trained = model.summary.light_chromaticity;
  if (!(trained.minCoeff() > 0.0f)) return std::nullopt;
  cv::Vec3d gains;
  for (int c = 0; c < 3; ++c) {
    if (!(seen.chromaticity[c] > 0.0)) return std::nullopt;
    gains[c] = trained[c] / seen.chromaticity[c];
  }
  return withCast(gains, std::numeric_limits<double>::infinity());
}

std::optional<LightRebalance> gated(std::optional<LightRebalance> rebalance, float min_cast) {
  if (!(min_cast > 0.0f) || !rebalance || rebalance->cast < min_cast) return std::nullopt;
  return rebalance;
}

// The frame with its colour rebalanced; depth and pose as they were.
RgbdFrame inTrainingLight(const RgbdFrame& frame, const LightRebalance& rebalance) {
  RgbdFrame rebalanced = frame;
  rebalanced.colour = applyChannelGains(frame.colour, rebalance.gains);
  return rebalanced;
}

}  // namespace

std::optional<LightChange> nearestViewLight(const LightGrid& seen,
                                            const std::vector<LightGrid>& views) {
  static const CandidateLights candidates;
  LightGrid ln_seen;
  for (size_t i = 0; i < seen.size(); ++i)
    ln_seen[i] = usable(seen[i]) ? std::log(seen[i]) : std::numeric_limits<float>::quiet_NaN();
  std::optional<LightChange> nearest;
  for (size_t view = 0; view < views.size(); ++view) {
    // Per channel: the usable cells, and the sum and square sum of their
    // ln ratios, from which every candidate light's fit follows.
    cv::Vec3d count(0, 0, 0), sum(0, 0, 0), square_sum(0, 0, 0);
    for (size_t i = 0; i < seen.size(); ++i) {
      if (std::isnan(ln_seen[i]) || !usable(views[view][i])) continue;
      const double ratio = ln_seen[i] - std::log(views[view][i]);
      count[i % 3] += 1.0;
      sum[i % 3] += ratio;
      square_sum[i % 3] += ratio * ratio;
    }
    const double values = count[0] + count[1] + count[2];
    if (values < kMinUsableValues) continue;
    for (size_t k = 0; k < candidates.kelvins.size(); ++k) {
      const cv::Vec3d& ln_gain = candidates.ln_gains[k];
      double shifted_sum = 0.0, shifted_square_sum = 0.0;
      for (int c = 0; c < 3; ++c) {
        shifted_sum += sum[c] - count[c] * ln_gain[c];
        shifted_square_sum +=
            square_sum[c] - 2.0 * ln_gain[c] * sum[c] + count[c] * ln_gain[c] * ln_gain[c];
      }
      const double ln_level = shifted_sum / values;
      const double mismatch = shifted_square_sum / values - ln_level * ln_level;
      if (!nearest || mismatch < nearest->mismatch)
        nearest = LightChange{ln_level / std::log(2.0), candidates.kelvins[k], mismatch, view};
    }
  }
  return nearest;
}

std::optional<LightRebalance> rebalanceIntoTrainingLight(const cv::Mat& bgr, const Model& model,
                                                         float min_cast) {
  if (!(min_cast > 0.0f)) return std::nullopt;
  return gated(rebalanceWithoutGate(SeenLight(bgr), model), min_cast);
}

PlaceAnswer searchedAgainInTrainingLight(const std::vector<std::shared_ptr<const Place>>& places,
                                         const RgbdFrame& frame, const PoseHint* hint,
                                         const PlaceSearchParams& params, PlaceAnswer first) {
  if (first.relocalization.success || places.size() < 2 || first.attempts.empty()) return first;
  for (const PlaceAttempt& attempt : first.attempts)
    if (attempt.success) return first;  // ambiguous
  // The light of the place whose training views the frame resembles most
  // once rebalanced; the best-screened place's when no place keeps its views.
  const std::string& best_screened = first.attempts.front().place;
  const SeenLight seen(frame.colour);
  const Place* lit_by = nullptr;
  std::optional<LightRebalance> rebalance;
  for (const auto& place : places) {
    if (place->relocalizer->params().light_retry_min_cast <= 0.0f) continue;
    std::optional<LightRebalance> candidate =
        rebalanceWithoutGate(seen, place->relocalizer->model());
    if (!candidate) continue;
    const bool nearer = !rebalance || candidate->mismatch < rebalance->mismatch ||
                        (std::isinf(rebalance->mismatch) && std::isinf(candidate->mismatch) &&
                         place->name == best_screened);
    if (nearer) {
      rebalance = candidate;
      lit_by = place.get();
    }
  }
  if (!lit_by) return first;
  rebalance = gated(rebalance, lit_by->relocalizer->params().light_retry_min_cast);
  if (!rebalance) return first;
  PlaceAnswer second = searchPlaces(places, inTrainingLight(frame, *rebalance), hint, params);
  float& cast = second.relocalization.light_cast;
  cast = std::max(cast, static_cast<float>(rebalance->cast));
  second.relocalization.timings.total += first.relocalization.timings.total;
  if (second.relocalization.success) return second;
  first.relocalization.message +=
      "; searched again in the light of " + lit_by->name + ": " + second.relocalization.message;
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
