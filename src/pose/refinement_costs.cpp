#include "relocalizer/pose/refinement_costs.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <cstring>

namespace relocalizer {

namespace {

// The Jacobians, with R = Exp(w) R0 and d/dw Exp(w) x = -[Exp(w) x]x J_l(w):
//   E_p: r = S (R c + t - mu);  dr/dv = S;  dr/dw = -S [R c]x J_l
//   E_l: r = S M (mu - A), M = I - D D^T, D = R d, A = R a + t (the line in
//        world coordinates);  dr/dv = -S M;
//        dr/dw = S ([R a]x + (D.m)[D]x + D m^T [D]x - D D^T [R a]x) J_l,  m = mu - A.

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Left Jacobian of SO(3).
Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d k = skew(w);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * k + k * k / 6.0;
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / theta2 * k +
         (theta - std::sin(theta)) / (theta2 * theta) * k * k;
}

// S with S^T S = information (the transposed Cholesky factor).
Eigen::Matrix3d sqrtInformation(const RefinementTerm& term) {
  return term.information.llt().matrixL().transpose();
}

using JacobianMap = Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>>;

}  // namespace

SharedPerturbation::SharedPerturbation(const Pose& base)
    : r0_(base.linear()), t0_(base.translation()) {}

void SharedPerturbation::update(const double* delta) {
  if (valid_ && std::memcmp(delta, delta_, sizeof delta_) == 0) return;
  std::memcpy(delta_, delta, sizeof delta_);
  const Eigen::Vector3d w(delta[3], delta[4], delta[5]);
  const double theta = w.norm();
  const Eigen::Matrix3d exp_w = theta < 1e-12
                                    ? Eigen::Matrix3d(Eigen::Matrix3d::Identity() + skew(w))
                                    : Eigen::Matrix3d(Eigen::AngleAxisd(theta, w / theta));
  r_ = exp_w * r0_;
  t_ = t0_ + Eigen::Vector3d(delta[0], delta[1], delta[2]);
  jl_ = so3LeftJacobian(w);
  valid_ = true;
}

PointToPointCost::PointToPointCost(const RefinementTerm& term, SharedPerturbation& pose)
    : camera_(term.camera_point),
      mean_(term.mode_mean),
      sqrt_information_(sqrtInformation(term)),
      pose_(pose) {}

bool PointToPointCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  pose_.update(parameters[0]);
  const Eigen::Vector3d rc = pose_.rotation() * camera_;
  Eigen::Map<Eigen::Vector3d> out(residuals);
  out = sqrt_information_ * (rc + pose_.translation() - mean_);
  if (jacobians && jacobians[0]) {
    JacobianMap j(jacobians[0]);
    j.leftCols<3>() = sqrt_information_;
    j.rightCols<3>() = -sqrt_information_ * skew(rc) * pose_.leftJacobian();
  }
  return true;
}

PointOnLineCost::PointOnLineCost(const RefinementTerm& term, SharedPerturbation& pose)
    : mean_(term.mode_mean),
      line_point_(term.line_point),
      line_direction_(term.line_direction),
      sqrt_information_(sqrtInformation(term)),
      pose_(pose) {}

bool PointOnLineCost::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  pose_.update(parameters[0]);
  const Eigen::Matrix3d& r = pose_.rotation();
  const Eigen::Vector3d d = r * line_direction_;
  const Eigen::Vector3d ra = r * line_point_;
  const Eigen::Vector3d m = mean_ - ra - pose_.translation();
  const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - d * d.transpose();
  Eigen::Map<Eigen::Vector3d> out(residuals);
  out = sqrt_information_ * (projector * m);
  if (jacobians && jacobians[0]) {
    JacobianMap j(jacobians[0]);
    const Eigen::Matrix3d skew_d = skew(d), skew_ra = skew(ra);
    j.leftCols<3>() = -sqrt_information_ * projector;
    j.rightCols<3>() = sqrt_information_ *
                       (skew_ra + d.dot(m) * skew_d + d * (m.transpose() * skew_d) -
                        d * (d.transpose() * skew_ra)) *
                       pose_.leftJacobian();
  }
  return true;
}

TermCosts::TermCosts(const std::vector<RefinementTerm>& terms, SharedPerturbation& pose) {
  size_t lines = 0;
  for (const RefinementTerm& term : terms) lines += term.on_line ? 1 : 0;
  points_ = std::make_unique<std::optional<PointToPointCost>[]>(terms.size() - lines);
  lines_ = std::make_unique<std::optional<PointOnLineCost>[]>(lines);
  costs_.reserve(terms.size());
  size_t point = 0, line = 0;
  for (const RefinementTerm& term : terms) {
    if (term.on_line)
      costs_.push_back(&lines_[line++].emplace(term, pose));
    else
      costs_.push_back(&points_[point++].emplace(term, pose));
  }
}

}  // namespace relocalizer
