#include "relocalizer/eval/simulated_hints.h"

#include <cmath>
#include <sstream>

#include "relocalizer/core/number_list.h"

namespace relocalizer {

namespace {

Eigen::Vector3d randomDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d v;
  do v = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
  while (v.norm() < 1e-9);
  return v.normalized();
}

}  // namespace

Expected<HintNoise> parseHintNoise(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return makeError("bad --hint '" + text + "': " + why +
                     " (expected ERROR_M,ERROR_DEG,SIGMA_M,SIGMA_DEG such as 0.1,3,0.3,10)");
  };
  auto values = parseNumberList(text);
  if (!values) return bad(values.error());
  if (values->size() != 4) return bad("expected four numbers");
  const HintNoise noise{(*values)[0], (*values)[1], (*values)[2], (*values)[3]};
  if (noise.error_metres < 0 || noise.error_degrees < 0) return bad("an error is negative");
  if (noise.sigma_metres <= 0 || noise.sigma_degrees <= 0) return bad("a sigma is not positive");
  return noise;
}

std::string formatHintNoise(const HintNoise& noise) {
  std::ostringstream out;
  out << noise.error_metres << " m, " << noise.error_degrees << " deg off; sigma "
      << noise.sigma_metres << " m, " << noise.sigma_degrees << " deg";
  return out.str();
}

SimulatedHints::SimulatedHints(const HintNoise& noise, std::string frame, unsigned seed)
    : noise_(noise), frame_(std::move(frame)), rng_(seed) {}

PoseHint SimulatedHints::around(const Pose& truth) {
  const double radians = noise_.error_degrees * M_PI / 180.0;
  const double sigma_radians = noise_.sigma_degrees * M_PI / 180.0;
  PoseHint hint;
  hint.frame = frame_;
  const Eigen::Vector3d shift = noise_.error_metres * randomDirection(rng_);
  const Eigen::AngleAxisd turn(radians, randomDirection(rng_));
  hint.pose = truth;
  hint.pose.linear() = turn.toRotationMatrix() * truth.linear();
  hint.pose.translation() += shift;
  hint.covariance.diagonal() << Eigen::Vector3d::Constant(noise_.sigma_metres *
                                                          noise_.sigma_metres),
      Eigen::Vector3d::Constant(sigma_radians * sigma_radians);
  return hint;
}

}  // namespace relocalizer
