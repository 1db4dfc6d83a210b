#include "relocalizer/pose/refinement.h"

#include <ceres/ceres.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <memory>

namespace relocalizer {

namespace {

// The Cauchy loss of every term, shared: neither the problem nor the
// covariance owns or copies it. Null (no loss) when robust_scale <= 0.
std::unique_ptr<ceres::LossFunction> robustLoss(const PoseSolverParams& params) {
  if (params.robust_scale <= 0) return nullptr;
  return std::make_unique<ceres::CauchyLoss>(params.robust_scale);
}

// The cost functions of a set of terms at one base pose.
struct PerturbedCosts {
  PerturbedCosts(const std::vector<RefinementTerm>& terms, const Pose& base)
      : pose(base), costs(terms, pose) {}
  SharedPerturbation pose;  // declared first: the costs refer to it
  TermCosts costs;
};

// Every term of a solve as one Ceres residual block, robust loss included.
// Ceres applies a loss to a whole block, so with a block per term its
// per-block machinery (validity checks, loss and corrector calls, Jacobian
// copies) cost several times the terms themselves. Here each term's loss is
// applied as Ceres' corrector would apply it to the term's own block: for the
// Cauchy loss (rho'' < 0 everywhere) residual and Jacobian scaled by
// sqrt(rho'(|r|^2)). That makes the Gauss-Newton model, gradient and model
// cost change the ones Ceres builds with a block per term; a last residual
// with a zero Jacobian row, sqrt(sum(rho(|r|^2) - |scaled r|^2)), makes the
// block's cost sum(rho(|r|^2)) / 2, the energy a block per term has. So the
// solver takes the same steps on the same energy, up to rounding.
class RobustTermsCost : public ceres::CostFunction {
 public:
  RobustTermsCost(const TermCosts& costs, const ceres::LossFunction* loss)
      : costs_(costs), loss_(loss) {
    set_num_residuals(static_cast<int>(3 * costs.size() + 1));
    mutable_parameter_block_sizes()->push_back(6);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    double* jacobian = jacobians ? jacobians[0] : nullptr;
    double excess = 0.0;  // sum of rho(|r|^2) - |scaled r|^2
    for (size_t i = 0; i < costs_.size(); ++i) {
      double* r = residuals + 3 * i;
      double* j = jacobian ? jacobian + 18 * i : nullptr;
      if (!costs_[i].Evaluate(parameters, r, j ? &j : nullptr)) return false;
      if (!loss_) continue;
      const double squared = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      double rho[3];
      loss_->Evaluate(squared, rho);
      const double scale = std::sqrt(rho[1]);
      for (int k = 0; k < 3; ++k) r[k] *= scale;
      if (j)
        for (int k = 0; k < 18; ++k) j[k] *= scale;
      excess += rho[0] - (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    }
    // rho(s) >= s rho'(s) for the Cauchy loss; rounding may dip below.
    residuals[3 * costs_.size()] = std::sqrt(std::max(0.0, excess));
    if (jacobian) std::fill_n(jacobian + 18 * costs_.size(), 6, 0.0);
    return true;
  }

 private:
  const TermCosts& costs_;
  const ceres::LossFunction* loss_;
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

// The terms a solve uses: a deterministic, evenly spread subset of at most
// max_refinement_terms bounds its cost (`subset` holds it); the covariance
// still uses every term.
const std::vector<RefinementTerm>& solveTerms(const std::vector<RefinementTerm>& terms,
                                              const PoseSolverParams& params,
                                              std::vector<RefinementTerm>& subset) {
  const size_t limit = params.max_refinement_terms > 0
                           ? static_cast<size_t>(params.max_refinement_terms)
                           : terms.size();
  if (terms.size() <= limit) return terms;
  subset.reserve(limit);
  for (size_t k = 0; k < limit; ++k) subset.push_back(terms[k * terms.size() / limit]);
  return subset;
}

}  // namespace

Refinement refinePose(const Pose& initial, const std::vector<RefinementTerm>& terms,
                      const PoseSolverParams& params, int max_iterations) {
  Refinement out;
  out.pose = initial;
  if (terms.size() < 3) {
    out.message = "fewer than 3 terms: nothing to refine on";
    return out;
  }
  const std::unique_ptr<ceres::LossFunction> loss = robustLoss(params);
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // The problem is built here, one parameter block and one residual block: the
  // checks would find nothing.
  problem_options.disable_all_safety_checks = true;

  std::vector<RefinementTerm> subset;
  double delta[6] = {0, 0, 0, 0, 0, 0};
  PerturbedCosts costs(solveTerms(terms, params, subset), initial);
  RobustTermsCost all_terms(costs.costs, loss.get());
  ceres::Problem problem(problem_options);
  problem.AddResidualBlock(&all_terms, nullptr, delta);
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
  out.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  // Running out of iterations is usable (NO_CONVERGENCE: the best pose so far);
  // a failure leaves delta where it was, and the start is returned as it came.
  if (!summary.IsSolutionUsable()) {
    out.message = "Ceres: " + summary.message;
    return out;
  }
  out.solved = true;
  out.pose = applyDelta(delta, initial);
  return out;
}

// Ceres would build the same Jacobians through a problem with a residual block
// per term for one evaluation; evaluating the cost functions directly and
// scaling them as Ceres' loss corrector does is cheaper: for the Cauchy loss
// (rho'' < 0) that is sqrt(rho'(|r|^2)) on every entry.
Matrix6d refinementCovariance(const Pose& pose, const std::vector<RefinementTerm>& terms,
                              const PoseSolverParams& params) {
  if (terms.size() < 3) return Matrix6d::Identity();
  const std::unique_ptr<ceres::LossFunction> loss = robustLoss(params);
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  const double* parameters[1] = {zero};
  PerturbedCosts at(terms, pose);
  Eigen::Matrix<double, 3, 6, Eigen::RowMajor> jacobian;
  double* jacobians[1] = {jacobian.data()};
  Eigen::Vector3d residual;
  Matrix6d information = Matrix6d::Zero();
  for (size_t i = 0; i < at.costs.size(); ++i) {
    at.costs[i].Evaluate(parameters, residual.data(), jacobians);
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

}  // namespace relocalizer
