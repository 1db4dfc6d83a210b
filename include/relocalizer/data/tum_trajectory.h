#pragma once
// TUM trajectory files: "timestamp tx ty tz qx qy qz qw" lines, '#' comments.
// TUM RGB-D's groundtruth.txt, synthesize's walk/walk_poses.txt, and what
// make_bag --tf-trajectory plays as TF.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"

namespace relocalizer {

struct TrajectorySample {
  double stamp;  // seconds
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;  // normalised
};

// The file's samples sorted by stamp (stably: equal stamps keep file order).
// Errors name the file and line: a line that is not 8 finite numbers, a
// zero-length quaternion.
Expected<std::vector<TrajectorySample>> readTumTrajectory(const std::string& file);

}  // namespace relocalizer
