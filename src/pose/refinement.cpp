#include "relocalizer/pose/refinement.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cstring>
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

// R, t and J_l at the parameters being evaluated, shared by every term of one
// problem. All terms have the one parameter block, and Ceres evaluates them one
// after another at the same values (num_threads = 1), so the exponential map
// and J_l, once two thirds of each term's cost, are computed once per
// evaluation point. Compared bit for bit, so the values are exactly those each term would
// compute for itself.
class SharedPerturbation {
 public:
  explicit SharedPerturbation(const Pose& base) : r0_(base.linear()), t0_(base.translation()) {}
  void update(const double* delta) {
    if (valid_ && std::memcmp(delta, delta_, sizeof delta_) == 0) return;
    std::memcpy(delta_, delta, sizeof delta_);
    perturbed(delta, r0_, t0_, r_, t_, jl_);
    valid_ = true;
  }
  const Eigen::Matrix3d& rotation() const { return r_; }
  const Eigen::Vector3d& translation() const { return t_; }
  const Eigen::Matrix3d& leftJacobian() const { return jl_; }

 private:
  Eigen::Matrix3d r0_;
  Eigen::Vector3d t0_;
  double delta_[6] = {0, 0, 0, 0, 0, 0};
  bool valid_ = false;
  Eigen::Matrix3d r_, jl_;
  Eigen::Vector3d t_;
};

Eigen::Matrix3d sqrtInformation(const RefinementTerm& term) {
  return term.information.llt().matrixL().transpose();
}

// E_p and E_l with their Jacobians (row-major 3 x 6, if `jacobian` is not
// null) at the shared pose.
void pointToPoint(const RefinementTerm& term, const Eigen::Matrix3d& sqrt_information,
                  const SharedPerturbation& pose, double* residuals, double* jacobian) {
  const Eigen::Vector3d rc = pose.rotation() * term.camera_point;
  Eigen::Map<Eigen::Vector3d> out(residuals);
  out = sqrt_information * (rc + pose.translation() - term.mode_mean);
  if (jacobian) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> j(jacobian);
    j.leftCols<3>() = sqrt_information;
    j.rightCols<3>() = -sqrt_information * skew(rc) * pose.leftJacobian();
  }
}

void pointOnLine(const RefinementTerm& term, const Eigen::Matrix3d& sqrt_information,
                 const SharedPerturbation& pose, double* residuals, double* jacobian) {
  const Eigen::Matrix3d& r = pose.rotation();
  const Eigen::Vector3d d = r * term.line_direction;
  const Eigen::Vector3d ra = r * term.line_point;
  const Eigen::Vector3d m = term.mode_mean - ra - pose.translation();
  const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - d * d.transpose();
  Eigen::Map<Eigen::Vector3d> out(residuals);
  out = sqrt_information * (projector * m);
  if (jacobian) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> j(jacobian);
    const Eigen::Matrix3d skew_d = skew(d), skew_ra = skew(ra);
    j.leftCols<3>() = -sqrt_information * projector;
    j.rightCols<3>() = sqrt_information *
                       (skew_ra + d.dot(m) * skew_d + d * (m.transpose() * skew_d) -
                        d * (d.transpose() * skew_ra)) *
                       pose.leftJacobian();
  }
}

// One term for Ceres: E_p or E_l with the hand-derived Jacobian.
class AnalyticTerm : public ceres::SizedCostFunction<3, 6> {
 public:
  AnalyticTerm(const RefinementTerm& term, SharedPerturbation& pose)
      : term_(term), pose_(pose), sqrt_information_(sqrtInformation(term)) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    pose_.update(parameters[0]);
    double* jacobian = jacobians ? jacobians[0] : nullptr;
    if (term_.on_line)
      pointOnLine(term_, sqrt_information_, pose_, residuals, jacobian);
    else
      pointToPoint(term_, sqrt_information_, pose_, residuals, jacobian);
    return true;
  }

 private:
  const RefinementTerm& term_;  // outlives the problem
  SharedPerturbation& pose_;
  Eigen::Matrix3d sqrt_information_;
};

// The cost functions of one problem, owned here rather than by the problem:
// a problem that owns them keeps a reference count per cost function (a map
// insert per term), which cost more than evaluating the term.
struct TermCosts {
  TermCosts(const std::vector<RefinementTerm>& terms, const Pose& base) : pose(base) {
    costs.reserve(terms.size());
    for (const RefinementTerm& term : terms) costs.push_back(std::make_unique<AnalyticTerm>(term, pose));
  }
  SharedPerturbation pose;
  std::vector<std::unique_ptr<AnalyticTerm>> costs;
};

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
  SharedPerturbation pose(base);
  AnalyticTerm(term, pose).Evaluate(parameters, residual.data(), analytic_blocks);
  if (term.on_line) {
    ceres::AutoDiffCostFunction<PointOnLineCost, 3, 6> reference(new PointOnLineCost(term, base));
    reference.Evaluate(parameters, out.residual.data(), autodiff_blocks);
  } else {
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
// inverted: the covariance of the left perturbation (v, w). The Jacobians are
// the cost functions' own, scaled as Ceres' loss corrector scales them: for
// the Cauchy loss (rho'' < 0) that is sqrt(rho'(|r|^2)) on every entry. No
// problem is built: that would cost a residual block per term for one
// evaluation.
Matrix6d covarianceAt(const Pose& pose, const std::vector<RefinementTerm>& terms,
                      const ceres::LossFunction* loss) {
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  SharedPerturbation at(pose);
  Eigen::Matrix<double, 3, 6, Eigen::RowMajor> jacobian;
  Eigen::Vector3d residual;
  Matrix6d information = Matrix6d::Zero();
  at.update(zero);
  for (const RefinementTerm& term : terms) {
    if (term.on_line)
      pointOnLine(term, sqrtInformation(term), at, residual.data(), jacobian.data());
    else
      pointToPoint(term, sqrtInformation(term), at, residual.data(), jacobian.data());
    if (loss) {
      double rho[3];
      // Ceres' expression, so the weight is the one it would apply.
      loss->Evaluate(Eigen::Map<const Eigen::VectorXd>(residual.data(), 3).squaredNorm(), rho);
      Eigen::Map<Eigen::VectorXd>(jacobian.data(), 18) *= std::sqrt(rho[1]);
    }
    for (int row = 0; row < 3; ++row) {
      const Eigen::Matrix<double, 6, 1> j = jacobian.row(row).transpose();
      information += j * j.transpose();
    }
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
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // The problem is built here, one parameter block and well-formed terms: the
  // per-term checks (a sort and allocation each) would find nothing.
  problem_options.disable_all_safety_checks = true;

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
  TermCosts costs(*solve_terms, initial);  // not const: the terms update its pose
  ceres::Problem problem(problem_options);
  for (const auto& cost : costs.costs) problem.AddResidualBlock(cost.get(), loss.get(), delta);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = max_iterations > 0 ? max_iterations : params.lm_iterations;
  options.num_threads = 1;  // SharedPerturbation relies on one evaluation at a time
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Pose refined = applyDelta(delta, initial);
  if (covariance) *covariance = covarianceAt(refined, terms, loss.get());
  return refined;
}

}  // namespace relocalizer
