#include "relocalizer/core/pose.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace relocalizer {

Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  // A reflection is not a rotation: flip the smallest singular direction.
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

Expected<Pose> poseFromMatrix(const Eigen::Matrix4d& m) {
  if (!m.allFinite()) return makeError("pose matrix contains NaN or Inf");
  if (std::abs(m(3, 0)) > 1e-6 || std::abs(m(3, 1)) > 1e-6 || std::abs(m(3, 2)) > 1e-6 ||
      std::abs(m(3, 3) - 1.0) > 1e-6)
    return makeError("pose matrix last row is not 0 0 0 1");
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if (std::abs(r.determinant() - 1.0) > 0.05)
    return makeError(
        "pose rotation block is not a rotation (det = " + std::to_string(r.determinant()) + ")");
  Pose pose = Pose::Identity();
  pose.linear() = nearestRotation(r);
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

double translationError(const Pose& estimate, const Pose& truth) {
  return (estimate.translation() - truth.translation()).norm();
}

bool posesAgree(const Pose& a, const Pose& b, double metres, double degrees) {
  return translationError(a, b) <= metres && rotationErrorDegrees(a, b) <= degrees;
}

double rotationErrorDegrees(const Pose& estimate, const Pose& truth) {
  const Eigen::Matrix3d relative =
      nearestRotation(estimate.linear()).transpose() * nearestRotation(truth.linear());
  // The quaternion form is well conditioned near 0 degrees, unlike acos(trace).
  const Eigen::Quaterniond q(relative);
  const double half = std::atan2(q.vec().norm(), std::abs(q.w()));
  return 2.0 * half * 180.0 / M_PI;
}

Pose poseFromTranslationQuaternion(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Pose pose = Pose::Identity();
  pose.linear() = q.normalized().toRotationMatrix();
  pose.translation() = t;
  return pose;
}

}  // namespace relocalizer
