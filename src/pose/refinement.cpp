#include "relocalizer/pose/refinement.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <memory>

namespace relocalizer {

namespace {

// Both are parameterised by a left perturbation delta = (v, w) of a fixed base
// pose: R = Exp(w) R0, t = t0 + v. The optimisation starts at delta = 0, and
// the same form at the solution gives the covariance in ROS's fixed-axis order.

template <typename T>
void perturbedPose(const T* delta, const Eigen::Matrix3d& r0, const Eigen::Vector3d& t0,
                   Eigen::Matrix<T, 3, 3>& r, Eigen::Matrix<T, 3, 1>& t) {
  T rotation[9];
  ceres::AngleAxisToRotationMatrix(delta + 3, ceres::ColumnMajorAdapter3x3(rotation));
  const Eigen::Map<const Eigen::Matrix<T, 3, 3>> exp_w(rotation);
  r = exp_w * r0.cast<T>();
  t = t0.cast<T>() + Eigen::Matrix<T, 3, 1>(delta[0], delta[1], delta[2]);
}

// E_p: whitened difference between the transformed camera point and its mode.
struct PointToPointCost {
  PointToPointCost(const RefinementTerm& term, const Pose& base)
      : camera(term.camera_point), mean(term.mode_mean), r0(base.linear()), t0(base.translation()) {
    sqrt_information = term.information.llt().matrixL().transpose();
  }
  template <typename T>
  bool operator()(const T* delta, T* residual) const {
    Eigen::Matrix<T, 3, 3> r;
    Eigen::Matrix<T, 3, 1> t;
    perturbedPose(delta, r0, t0, r, t);
    const Eigen::Matrix<T, 3, 1> error = r * camera.cast<T>() + t - mean.cast<T>();
    Eigen::Map<Eigen::Matrix<T, 3, 1>> out(residual);
    out = sqrt_information.cast<T>() * error;
    return true;
  }
  Eigen::Vector3d camera, mean;
  Eigen::Matrix3d r0;
  Eigen::Vector3d t0;
  Eigen::Matrix3d sqrt_information;  // L^T with Sigma^-1 = L L^T
};

// E_l: the predicted world point moved into the camera frame, its offset from
// the sample's 3D line, weighted by the mode covariance rotated into the camera
// frame: r^T (R^T Sigma R)^-1 r = |L^T R r|^2.
struct PointOnLineCost {
  PointOnLineCost(const RefinementTerm& term, const Pose& base)
      : mean(term.mode_mean),
        line_point(term.line_point),
        line_direction(term.line_direction),
        r0(base.linear()),
        t0(base.translation()) {
    sqrt_information = term.information.llt().matrixL().transpose();
  }
  template <typename T>
  bool operator()(const T* delta, T* residual) const {
    Eigen::Matrix<T, 3, 3> r;
    Eigen::Matrix<T, 3, 1> t;
    perturbedPose(delta, r0, t0, r, t);
    const Eigen::Matrix<T, 3, 1> in_camera = r.transpose() * (mean.cast<T>() - t);
    const Eigen::Matrix<T, 3, 1> offset = in_camera - line_point.cast<T>();
    const Eigen::Matrix<T, 3, 1> d = line_direction.cast<T>();
    const Eigen::Matrix<T, 3, 1> perpendicular = offset - d * d.dot(offset);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> out(residual);
    out = sqrt_information.cast<T>() * (r * perpendicular);
    return true;
  }
  Eigen::Vector3d mean, line_point, line_direction;
  Eigen::Matrix3d r0;
  Eigen::Vector3d t0;
  Eigen::Matrix3d sqrt_information;
};

// The same two energies with hand-derived Jacobians: the refinement runs
// thousands of residual evaluations per frame, and these are several times
// cheaper than dual numbers. The autodiff functors above stay the reference
// (a unit test compares the Jacobians).
//
// With R = Exp(w) R0 and d/dw Exp(w) x = -[Exp(w) x]x J_l(w):
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
Eigen::Matrix3d leftJacobian(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d k = skew(w);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * k + k * k / 6.0;
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / theta2 * k +
         (theta - std::sin(theta)) / (theta2 * theta) * k * k;
}

void perturbed(const double* delta, const Eigen::Matrix3d& r0, const Eigen::Vector3d& t0,
               Eigen::Matrix3d& r, Eigen::Vector3d& t, Eigen::Matrix3d& jl) {
  const Eigen::Vector3d w(delta[3], delta[4], delta[5]);
  const double theta = w.norm();
  const Eigen::Matrix3d exp_w = theta < 1e-12 ? Eigen::Matrix3d(Eigen::Matrix3d::Identity() + skew(w))
                                              : Eigen::Matrix3d(Eigen::AngleAxisd(theta, w / theta));
  r = exp_w * r0;
  t = t0 + Eigen::Vector3d(delta[0], delta[1], delta[2]);
  jl = leftJacobian(w);
}

class PointToPointAnalytic : public ceres::SizedCostFunction<3, 6> {
 public:
  PointToPointAnalytic(const RefinementTerm& term, const Pose& base)
      : camera_(term.camera_point), mean_(term.mode_mean), r0_(base.linear()), t0_(base.translation()),
        sqrt_information_(term.information.llt().matrixL().transpose()) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Matrix3d r, jl;
    Eigen::Vector3d t;
    perturbed(parameters[0], r0_, t0_, r, t, jl);
    const Eigen::Vector3d rc = r * camera_;
    Eigen::Map<Eigen::Vector3d> out(residuals);
    out = sqrt_information_ * (rc + t - mean_);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> j(jacobians[0]);
      j.leftCols<3>() = sqrt_information_;
      j.rightCols<3>() = -sqrt_information_ * skew(rc) * jl;
    }
    return true;
  }

 private:
  Eigen::Vector3d camera_, mean_;
  Eigen::Matrix3d r0_;
  Eigen::Vector3d t0_;
  Eigen::Matrix3d sqrt_information_;
};

class PointOnLineAnalytic : public ceres::SizedCostFunction<3, 6> {
 public:
  PointOnLineAnalytic(const RefinementTerm& term, const Pose& base)
      : mean_(term.mode_mean), line_point_(term.line_point), line_direction_(term.line_direction),
        r0_(base.linear()), t0_(base.translation()),
        sqrt_information_(term.information.llt().matrixL().transpose()) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Matrix3d r, jl;
    Eigen::Vector3d t;
    perturbed(parameters[0], r0_, t0_, r, t, jl);
    const Eigen::Vector3d d = r * line_direction_;
    const Eigen::Vector3d ra = r * line_point_;
    const Eigen::Vector3d m = mean_ - ra - t;
    const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - d * d.transpose();
    Eigen::Map<Eigen::Vector3d> out(residuals);
    out = sqrt_information_ * (projector * m);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> j(jacobians[0]);
      const Eigen::Matrix3d skew_d = skew(d), skew_ra = skew(ra);
      j.leftCols<3>() = -sqrt_information_ * projector;
      j.rightCols<3>() = sqrt_information_ *
                         (skew_ra + d.dot(m) * skew_d + d * (m.transpose() * skew_d) -
                          d * (d.transpose() * skew_ra)) *
                         jl;
    }
    return true;
  }

 private:
  Eigen::Vector3d mean_, line_point_, line_direction_;
  Eigen::Matrix3d r0_;
  Eigen::Vector3d t0_;
  Eigen::Matrix3d sqrt_information_;
};

void addTerms(ceres::Problem& problem, double* delta, const std::vector<RefinementTerm>& terms,
              const Pose& base, ceres::LossFunction* loss) {
  for (const RefinementTerm& term : terms) {
    if (term.on_line)
      problem.AddResidualBlock(new PointOnLineAnalytic(term, base), loss, delta);
    else
      problem.AddResidualBlock(new PointToPointAnalytic(term, base), loss, delta);
  }
}

Pose applyDelta(const double* delta, const Pose& base) {
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  perturbedPose(delta, base.linear(), base.translation(), r, t);
  Pose out = Pose::Identity();
  out.linear() = nearestRotation(r);
  out.translation() = t;
  return out;
}

}  // namespace

ResidualJacobians residualJacobians(const Pose& base, const RefinementTerm& term,
                                    const double* delta) {
  ResidualJacobians out;
  double* analytic_blocks[1] = {out.analytic.data()};
  double* autodiff_blocks[1] = {out.autodiff.data()};
  const double* parameters[1] = {delta};
  Eigen::Vector3d residual;
  if (term.on_line) {
    PointOnLineAnalytic(term, base).Evaluate(parameters, residual.data(), analytic_blocks);
    ceres::AutoDiffCostFunction<PointOnLineCost, 3, 6> reference(new PointOnLineCost(term, base));
    reference.Evaluate(parameters, out.residual.data(), autodiff_blocks);
  } else {
    PointToPointAnalytic(term, base).Evaluate(parameters, residual.data(), analytic_blocks);
    ceres::AutoDiffCostFunction<PointToPointCost, 3, 6> reference(new PointToPointCost(term, base));
    reference.Evaluate(parameters, out.residual.data(), autodiff_blocks);
  }
  out.residual_difference = (residual - out.residual).norm();
  return out;
}

Eigen::Vector3d pointResidual(const Pose& pose, const RefinementTerm& term) {
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  Eigen::Vector3d r;
  PointToPointCost(term, pose)(zero, r.data());
  return r;
}

Eigen::Vector3d lineResidual(const Pose& pose, const RefinementTerm& term) {
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  Eigen::Vector3d r;
  PointOnLineCost(term, pose)(zero, r.data());
  return r;
}

namespace {

// Gauss-Newton information of all terms at `pose`, robust weights included,
// inverted: the covariance of the left perturbation (v, w).
Matrix6d covarianceAt(const Pose& pose, const std::vector<RefinementTerm>& terms,
                      ceres::LossFunction* loss, const ceres::Problem::Options& problem_options) {
  double zero[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem at_solution(problem_options);
  addTerms(at_solution, zero, terms, pose, loss);
  ceres::CRSMatrix jacobian;
  at_solution.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, nullptr, &jacobian);
  Matrix6d information = Matrix6d::Zero();
  for (int row = 0; row < jacobian.num_rows; ++row) {
    Eigen::Matrix<double, 6, 1> j = Eigen::Matrix<double, 6, 1>::Zero();
    for (int k = jacobian.rows[row]; k < jacobian.rows[row + 1]; ++k)
      j(jacobian.cols[k]) = jacobian.values[k];
    information += j * j.transpose();
  }
  Eigen::FullPivLU<Matrix6d> lu(information);
  return lu.isInvertible() ? Matrix6d(lu.inverse()) : Matrix6d(Matrix6d::Identity() * 1e6);
}

}  // namespace

Pose refinePose(const Pose& initial, const std::vector<RefinementTerm>& terms,
                const PoseSolverParams& params, Matrix6d* covariance, int max_iterations) {
  if (terms.size() < 3) {
    if (covariance) covariance->setIdentity();
    return initial;
  }
  // One loss object for every term: the problem does not own or copy it.
  std::unique_ptr<ceres::LossFunction> loss;
  if (params.robust_scale > 0) loss = std::make_unique<ceres::CauchyLoss>(params.robust_scale);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;

  // A deterministic, evenly spread subset bounds the solve's cost; the
  // covariance below still uses every term.
  const size_t limit = params.max_refinement_terms > 0 ? static_cast<size_t>(params.max_refinement_terms)
                                                       : terms.size();
  std::vector<RefinementTerm> subset;
  const std::vector<RefinementTerm>* solve_terms = &terms;
  if (terms.size() > limit) {
    subset.reserve(limit);
    for (size_t k = 0; k < limit; ++k) subset.push_back(terms[k * terms.size() / limit]);
    solve_terms = &subset;
  }

  double delta[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem problem(problem_options);
  addTerms(problem, delta, *solve_terms, initial, loss.get());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = max_iterations > 0 ? max_iterations : params.lm_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Pose refined = applyDelta(delta, initial);
  if (covariance) *covariance = covarianceAt(refined, terms, loss.get(), problem_options);
  return refined;
}

}  // namespace relocalizer
