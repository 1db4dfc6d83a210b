#include "relocalizer/pose_solver.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <memory>
#include <numeric>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace relocalizer {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// --- Ceres cost functors ------------------------------------------------------------
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

// --- RANSAC bookkeeping ---------------------------------------------------------

// Candidate modes of one batch sample, copied contiguously so that scoring
// hundreds of hypotheses reads a compact block instead of chasing pointers.
struct BatchEntry {
  Eigen::Vector3f camera;
  int count;
  int sample;  // index into the combined sample list
};
struct BatchMode {
  Eigen::Vector3f mean;
  std::array<float, 6> information;
};

struct Hypothesis {
  Pose pose;
  Eigen::Matrix3f rotation;
  Eigen::Vector3f translation;
  int score = 0;  // inliers accumulated over rounds
  // Kabsch statistics of the inliers accumulated over rounds.
  double n = 0;
  Eigen::Vector3d sum_camera = Eigen::Vector3d::Zero(), sum_world = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();  // sum world * camera^T
  int index = 0;

  void setPose(const Pose& p) {
    pose = p;
    rotation = p.linear().cast<float>();
    translation = p.translation().cast<float>();
  }
};

// Scores up to kLanes hypotheses at once on a batch: each sample's transformed
// camera point and candidate distances are computed for all lanes with packet
// arithmetic (Eigen arrays), which is where preemptive RANSAC spends its time.
// Per lane, the best candidate under `chi2` makes the sample an inlier: the
// score and the Kabsch statistics of the hypothesis are updated.
constexpr size_t kLanes = 8;
using Lanes = Eigen::Array<float, kLanes, 1>;
using LaneIndices = Eigen::Array<int, kLanes, 1>;

void scoreBlock(Hypothesis* block, int count, const std::vector<BatchEntry>& batch,
                const std::vector<BatchMode>& batch_modes, float chi2) {
  Lanes r[9], t[3];
  for (int l = 0; l < static_cast<int>(kLanes); ++l) {
    // Unused lanes repeat the first hypothesis; their results are dropped.
    const Hypothesis& h = block[l < count ? l : 0];
    for (int k = 0; k < 9; ++k) r[k](l) = h.rotation(k / 3, k % 3);
    for (int k = 0; k < 3; ++k) t[k](l) = h.translation(k);
  }
  const BatchMode* modes = batch_modes.data();
  for (const BatchEntry& e : batch) {
    const float cx = e.camera.x(), cy = e.camera.y(), cz = e.camera.z();
    const Lanes wx = r[0] * cx + r[1] * cy + r[2] * cz + t[0];
    const Lanes wy = r[3] * cx + r[4] * cy + r[5] * cz + t[1];
    const Lanes wz = r[6] * cx + r[7] * cy + r[8] * cz + t[2];
    Lanes best = Lanes::Constant(chi2);
    LaneIndices chosen = LaneIndices::Constant(-1);
    for (int c = 0; c < e.count; ++c) {
      const BatchMode& m = modes[c];
      const auto& s = m.information;
      const Lanes dx = wx - m.mean.x(), dy = wy - m.mean.y(), dz = wz - m.mean.z();
      const Lanes d = s[0] * dx * dx + s[3] * dy * dy + s[5] * dz * dz +
                      2.0f * (s[1] * dx * dy + s[2] * dx * dz + s[4] * dy * dz);
      // Materialised: a lazy (d < best) would be re-read after best changes.
      const Eigen::Array<bool, kLanes, 1> better = d < best;
      best = better.select(d, best);
      chosen = better.select(LaneIndices::Constant(c), chosen);
    }
    if ((chosen >= 0).any()) {
      const Eigen::Vector3d camera = e.camera.cast<double>();
      for (int l = 0; l < count; ++l) {
        if (chosen(l) < 0) continue;
        Hypothesis& hyp = block[l];
        const Eigen::Vector3d mean = modes[chosen(l)].mean.cast<double>();
        ++hyp.score;
        hyp.n += 1.0;
        hyp.sum_camera += camera;
        hyp.sum_world += mean;
        hyp.cross += mean * camera.transpose();
      }
    }
    modes += e.count;
  }
}

// Index of the candidate mode that best explains `world`, and its distance.
inline int bestMode(const Prediction& prediction, const Eigen::Vector3f& world, float& best) {
  int chosen = -1;
  best = std::numeric_limits<float>::max();
  for (int c = 0; c < prediction.count; ++c) {
    const LeafMode& m = *prediction.candidates[c].mode;
    const float e = m.mahalanobisSquared(world);
    if (e < best) {
      best = e;
      chosen = c;
    }
  }
  return chosen;
}

Eigen::Matrix3d informationOf(const LeafMode& mode) { return mode.informationMatrix().cast<double>(); }

// Refinement terms for every sample that is an inlier of `pose`.
void collectTerms(const std::vector<const SolverSample*>& samples, const Pose& pose,
                  const PoseSolverParams& params, std::vector<RefinementTerm>& terms,
                  int* point_inliers, int* line_inliers) {
  terms.clear();
  int points = 0, lines = 0;
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  for (const SolverSample* s : samples) {
    float distance = 0;
    const int c = bestMode(*s->prediction, r * s->camera_point + t, distance);
    if (c < 0 || distance >= params.inlier_chi2) continue;
    const LeafMode& mode = *s->prediction->candidates[c].mode;
    RefinementTerm term;
    term.camera_point = s->camera_point.cast<double>();
    term.mode_mean = mode.mean.cast<double>();
    term.information = informationOf(mode);
    if (s->line) {
      ++lines;
      term.on_line = params.use_lines_in_refinement;
      term.line_point = s->line->point.cast<double>();
      term.line_direction = s->line->direction.cast<double>();
    } else {
      ++points;
    }
    terms.push_back(term);
  }
  if (point_inliers) *point_inliers = points;
  if (line_inliers) *line_inliers = lines;
}

}  // namespace

bool kabsch(const Eigen::Vector3d* camera, const Eigen::Vector3d* world, const double* weights,
            int count, Pose& pose) {
  if (count < 3) return false;
  double total = 0.0;
  Eigen::Vector3d mean_c = Eigen::Vector3d::Zero(), mean_w = Eigen::Vector3d::Zero();
  for (int i = 0; i < count; ++i) {
    const double w = weights ? weights[i] : 1.0;
    total += w;
    mean_c += w * camera[i];
    mean_w += w * world[i];
  }
  if (total <= 0.0) return false;
  mean_c /= total;
  mean_w /= total;
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i)
    cross += (weights ? weights[i] : 1.0) * (world[i] - mean_w) * (camera[i] - mean_c).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Rank below 2 (collinear points) leaves the rotation about the line free.
  if (svd.singularValues()(1) < 1e-12 * std::max(1.0, svd.singularValues()(0))) return false;
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
  pose = Pose::Identity();
  pose.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  pose.translation() = mean_w - pose.linear() * mean_c;
  return true;
}

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

  if (covariance) {
    // Gauss-Newton information at the solution, robust weights included.
    double zero[6] = {0, 0, 0, 0, 0, 0};
    ceres::Problem at_solution(problem_options);
    addTerms(at_solution, zero, terms, refined, loss.get());
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
    *covariance = lu.isInvertible() ? Matrix6d(lu.inverse()) : Matrix6d(Matrix6d::Identity() * 1e6);
  }
  return refined;
}

PoseSolution solvePose(const std::vector<SolverSample>& points,
                       const std::vector<SolverSample>& lines, const PoseSolverParams& params,
                       std::mt19937& rng) {
  PoseSolution solution;
  const auto ransac_start = Clock::now();
  double lm_seconds = 0.0;

  // Samples with at least one candidate mode; points first.
  std::vector<const SolverSample*> all;
  for (const auto& s : points)
    if (s.prediction && s.prediction->count > 0) all.push_back(&s);
  const int point_count = static_cast<int>(all.size());
  for (const auto& s : lines)
    if (s.prediction && s.prediction->count > 0 && s.line) all.push_back(&s);
  solution.samples = static_cast<int>(all.size());
  if (point_count < 3) {
    solution.message = "too few point predictions for a pose (" + std::to_string(point_count) +
                       "; need at least 3)";
    return solution;
  }

  // --- Hypotheses from minimal sets -----------------------------------------------
  std::vector<Hypothesis> hypotheses;
  hypotheses.reserve(params.hypotheses);
  std::uniform_int_distribution<int> pick_point(0, point_count - 1);
  const float min_d2 = params.min_point_distance * params.min_point_distance;
  const int max_attempts = params.hypotheses * std::max(1, params.max_sampling_attempts);
  for (int attempt = 0; attempt < max_attempts && static_cast<int>(hypotheses.size()) < params.hypotheses;
       ++attempt) {
    const int i0 = pick_point(rng), i1 = pick_point(rng), i2 = pick_point(rng);
    if (i0 == i1 || i0 == i2 || i1 == i2) continue;
    const SolverSample* s[3] = {all[i0], all[i1], all[i2]};
    Eigen::Vector3d camera[3], world[3];
    for (int k = 0; k < 3; ++k) {
      std::uniform_int_distribution<int> pick_mode(0, s[k]->prediction->count - 1);
      camera[k] = s[k]->camera_point.cast<double>();
      world[k] = s[k]->prediction->candidates[pick_mode(rng)].mode->mean.cast<double>();
    }
    bool ok = true;
    for (int a = 0; a < 3 && ok; ++a) {
      const int b = (a + 1) % 3;
      const double dc = (camera[a] - camera[b]).norm(), dw = (world[a] - world[b]).norm();
      if (dc * dc < min_d2) ok = false;
      const double tolerance = std::max<double>(params.rigidity_tolerance, params.rigidity_ratio * dc);
      if (std::abs(dc - dw) > tolerance) ok = false;
    }
    // Nearly collinear triples leave the rotation about their line undetermined.
    if (ok && (camera[1] - camera[0]).cross(camera[2] - camera[0]).norm() < 0.5 * min_d2) ok = false;
    if (!ok) continue;
    Pose pose;
    if (!kabsch(camera, world, nullptr, 3, pose)) continue;
    Hypothesis h;
    h.setPose(pose);
    h.index = static_cast<int>(hypotheses.size());
    hypotheses.push_back(h);
  }
  solution.valid_hypotheses = static_cast<int>(hypotheses.size());
  if (hypotheses.empty()) {
    solution.message = "no pose hypothesis passed the rigidity checks (" +
                       std::to_string(max_attempts) + " minimal sets tried)";
    solution.ransac_seconds = secondsSince(ransac_start);
    return solution;
  }

  // --- Preemptive rounds ------------------------------------------------------------
  std::vector<int> order(all.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  size_t next_sample = 0;
  std::vector<BatchEntry> batch;
  std::vector<BatchMode> batch_modes;
  std::vector<RefinementTerm> terms;
  std::vector<const SolverSample*> seen;
  const int batch_size = std::max(1, params.batch_size);
  while (true) {
    batch.clear();
    batch_modes.clear();
    for (int k = 0; k < batch_size && k < static_cast<int>(all.size()); ++k) {
      if (next_sample == order.size()) {
        next_sample = 0;  // pool exhausted: score the same samples again
      }
      const int index = order[next_sample++];
      const SolverSample& s = *all[index];
      batch.push_back({s.camera_point, s.prediction->count, index});
      for (int c = 0; c < s.prediction->count; ++c) {
        const LeafMode& m = *s.prediction->candidates[c].mode;
        batch_modes.push_back({m.mean, m.information});
      }
    }
    const size_t blocks = (hypotheses.size() + kLanes - 1) / kLanes;
    tbb::parallel_for(size_t{0}, blocks, [&](size_t b) {
      scoreBlock(hypotheses.data() + b * kLanes,
                 static_cast<int>(std::min(kLanes, hypotheses.size() - b * kLanes)), batch,
                 batch_modes, params.inlier_chi2);
    });
    // Deterministic order: score, then creation index.
    std::sort(hypotheses.begin(), hypotheses.end(), [](const Hypothesis& a, const Hypothesis& b) {
      return a.score != b.score ? a.score > b.score : a.index < b.index;
    });
    if (hypotheses.size() == 1) break;
    hypotheses.resize((hypotheses.size() + 1) / 2);

    if (static_cast<int>(hypotheses.size()) > params.lm_hypotheses) {
      // Weighted-Kabsch refit from the accumulated inlier statistics.
      tbb::parallel_for(size_t{0}, hypotheses.size(), [&](size_t h) {
        Hypothesis& hyp = hypotheses[h];
        if (hyp.n < 3) return;
        const Eigen::Vector3d mc = hyp.sum_camera / hyp.n, mw = hyp.sum_world / hyp.n;
        const Eigen::Matrix3d cov = hyp.cross / hyp.n - mw * mc.transpose();
        Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
        if (svd.singularValues()(1) < 1e-9) return;
        Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
        if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
        Pose p = Pose::Identity();
        p.linear() = svd.matrixU() * d * svd.matrixV().transpose();
        p.translation() = mw - p.linear() * mc;
        hyp.setPose(p);
      });
    } else {
      // Few left: Levenberg-Marquardt on this round's inliers, in parallel.
      const auto lm_start = Clock::now();
      seen.clear();
      for (const BatchEntry& e : batch) seen.push_back(all[e.sample]);
      tbb::parallel_for(size_t{0}, hypotheses.size(), [&](size_t h) {
        Hypothesis& hyp = hypotheses[h];
        std::vector<RefinementTerm> hypothesis_terms;
        collectTerms(seen, hyp.pose, params, hypothesis_terms, nullptr, nullptr);
        if (hypothesis_terms.size() >= 3)
          hyp.setPose(refinePose(hyp.pose, hypothesis_terms, params, nullptr, params.lm_loop_iterations));
      });
      lm_seconds += secondsSince(lm_start);
    }
  }
  solution.ransac_seconds = secondsSince(ransac_start) - lm_seconds;

  // --- Final refinement on all samples ----------------------------------------------
  const auto refine_start = Clock::now();
  Pose pose = hypotheses.front().pose;
  for (int pass = 0; pass < 2; ++pass) {
    collectTerms(all, pose, params, terms, nullptr, nullptr);
    if (terms.size() < 3) break;
    pose = refinePose(pose, terms, params);
  }
  collectTerms(all, pose, params, terms, &solution.point_inliers, &solution.line_inliers);
  if (terms.size() >= 3) refinePose(pose, terms, params, &solution.covariance);
  solution.refinement_seconds = lm_seconds + secondsSince(refine_start);
  solution.pose = pose;
  const int inliers = solution.point_inliers + solution.line_inliers;
  solution.score = all.empty() ? 0.0f : static_cast<float>(inliers) / all.size();
  if (inliers < params.min_inliers || solution.score < params.min_inlier_ratio) {
    char buffer[200];
    std::snprintf(buffer, sizeof buffer,
                  "weak evidence: %d inliers (%.1f%% of %zu samples); need %d and %.1f%%", inliers,
                  100.0 * solution.score, all.size(), params.min_inliers,
                  100.0 * params.min_inlier_ratio);
    solution.message = buffer;
    return solution;
  }
  solution.success = true;
  return solution;
}

}  // namespace relocalizer
