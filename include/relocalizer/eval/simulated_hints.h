#pragma once
// Pose hints made from ground truth, to measure what a hint buys where the
// frame alone cannot tell two places apart (look-alike rooms of one
// building). A SLAM system that has just lost tracking, or an operator, knows
// roughly where the camera is: each hint is the true pose moved by an error of
// a fixed size in a random direction, declared with standard deviations that
// may be larger than that error (pose_hint.h weighs answers by them). Seeded,
// so an evaluation repeats.

#include <random>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/pose/pose_hint.h"

namespace relocalizer {

struct HintNoise {
  double error_metres = 0.0, error_degrees = 0.0;  // how far each hint is from the truth
  double sigma_metres = 0.0, sigma_degrees = 0.0;  // what it declares, per axis
};

// "ERROR_M,ERROR_DEG,SIGMA_M,SIGMA_DEG" (e.g. 0.1,3,0.3,10); the sigmas must be
// positive, the errors at least 0.
Expected<HintNoise> parseHintNoise(const std::string& text);
std::string formatHintNoise(const HintNoise& noise);

class SimulatedHints {
 public:
  // Hints in `frame`, the map frame of the places they should reach
  // (place_set.h); empty for a single model.
  SimulatedHints(const HintNoise& noise, std::string frame, unsigned seed = 1);

  // A hint for a camera truly at `truth` (camera-to-world): its position moved
  // by error_metres, its orientation turned by error_degrees about the map's
  // axes, both in random directions.
  PoseHint around(const Pose& truth);

 private:
  HintNoise noise_;
  std::string frame_;
  std::mt19937 rng_;
};

}  // namespace relocalizer
