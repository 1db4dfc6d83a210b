#pragma once
// Kabsch: the rigid transform that best maps one point set onto another in the
// least-squares sense. Pose hypotheses (three camera points onto their world
// modes), the refits of preemptive RANSAC and the ATE's trajectory alignment
// all use this one solution.

#include <Eigen/Core>

#include "relocalizer/core/pose.h"

namespace relocalizer {

// T minimising sum_i |T source_i - target_i|^2 over rigid T: Eigen::umeyama
// without scaling. False for fewer than 3 pairs (pose untouched), and for
// points so close to one line that the rotation about it is free (pose is then
// one of the equally good answers, which is enough to measure residuals but not
// to trust as a pose).
bool kabsch(const Eigen::Vector3d* source, const Eigen::Vector3d* target, int count, Pose& pose);

// Running sums over matched pairs, for callers that gather pairs a few at a
// time and never keep them (preemptive RANSAC accumulates inliers round by round).
struct AlignmentSums {
  double count = 0.0;
  Eigen::Vector3d source = Eigen::Vector3d::Zero();  // sum of source points
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // sum of target points
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();   // sum of target source^T

  void add(const Eigen::Vector3d& source_point, const Eigen::Vector3d& target_point) {
    count += 1.0;
    source += source_point;
    target += target_point;
    cross += target_point * source_point.transpose();
  }
};

// The same T from the sums: the rotation is the nearest rotation to the
// centred cross-covariance, as in Kabsch and Umeyama. False (pose untouched)
// for fewer than 3 pairs or a cross-covariance of rank below 2.
bool kabsch(const AlignmentSums& sums, Pose& pose);

}  // namespace relocalizer
