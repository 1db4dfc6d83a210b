#pragma once
// Mean shift with a Gaussian kernel on 3D world coordinates: the modes a leaf
// stores. A leaf reached by pixels of several repeated structures (two
// identical chairs, say) has several modes; averaging them would predict a
// point between the chairs that belongs to neither.

#include <Eigen/Core>
#include <vector>

namespace relocalizer {

struct MeanShiftParams {
  float bandwidth = 0.05f;      // Gaussian kernel sigma, metres
  int max_seeds = 64;           // seeds are spread evenly over the points
  int max_iterations = 8;       // 20 until issue 28: the same forests' accuracy
  int max_modes = 4;            // strongest modes kept
  float min_mode_share = 0.1f;  // of the points; weaker modes are dropped
  float min_std = 0.01f;        // covariance floor (metres): depth noise and few samples
};

struct Mode3D {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  Eigen::Matrix3f covariance = Eigen::Matrix3f::Identity();
  int support = 0;
};

// Modes ordered by decreasing support. `assignment`, if given, receives for
// each point the index of its mode, or -1 if its mode was dropped.
// Deterministic: no randomness, seeds chosen by stride.
std::vector<Mode3D> meanShiftModes(const std::vector<Eigen::Vector3f>& points,
                                   const MeanShiftParams& params,
                                   std::vector<int>* assignment = nullptr);

}  // namespace relocalizer
