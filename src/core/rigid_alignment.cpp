#include "relocalizer/core/rigid_alignment.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>

namespace relocalizer {

bool kabsch(const Eigen::Vector3d* source, const Eigen::Vector3d* target, int count, Pose& pose) {
  if (count < 3) return false;
  // Vector3d holds three packed doubles, so arrays of them are 3xN matrices.
  const Eigen::Map<const Eigen::Matrix3Xd> from(source->data(), 3, count);
  const Eigen::Map<const Eigen::Matrix3Xd> to(target->data(), 3, count);
  pose = Pose(Eigen::umeyama(from, to, false));
  // Umeyama does not say when the problem is degenerate; the singular values
  // of the cross-covariance do: rank below 2 (collinear points) leaves a
  // rotation free.
  const Eigen::Matrix3d cross =
      (to.colwise() - to.rowwise().mean()) * (from.colwise() - from.rowwise().mean()).transpose();
  const Eigen::Vector3d singular = Eigen::JacobiSVD<Eigen::Matrix3d>(cross).singularValues();
  return singular(1) >= 1e-12 * std::max(1.0, singular(0));
}

bool kabsch(const AlignmentSums& sums, Pose& pose) {
  if (sums.count < 3) return false;
  const Eigen::Vector3d mean_source = sums.source / sums.count;
  const Eigen::Vector3d mean_target = sums.target / sums.count;
  const Eigen::Matrix3d covariance =
      sums.cross / sums.count - mean_target * mean_source.transpose();
  if (Eigen::JacobiSVD<Eigen::Matrix3d>(covariance).singularValues()(1) < 1e-9) return false;
  pose = Pose::Identity();
  pose.linear() = nearestRotation(covariance);
  pose.translation() = mean_target - pose.linear() * mean_source;
  return true;
}

}  // namespace relocalizer
