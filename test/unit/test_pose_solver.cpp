#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>
#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>

#include "relocalizer/core/rigid_alignment.h"
#include "relocalizer/pose/lane_scoring.h"
#include "relocalizer/pose/pose_solver.h"
#include "relocalizer/pose/refinement.h"
#include "relocalizer/pose/refinement_costs.h"
#include "relocalizer/relocalize/relocalizer.h"  // ScreenParams: the screen's budget (a plain struct)

using namespace relocalizer;

namespace {

Pose makePose(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Pose p = Pose::Identity();
  p.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

LeafMode isotropicMode(const Eigen::Vector3f& mean, float sigma) {
  LeafMode m;
  m.mean = mean;
  m.setCovariance(Eigen::Matrix3f::Identity() * sigma * sigma);
  return m;
}

// A synthetic correspondence set: camera points in front of the camera, their
// true world points, and a share of samples whose every candidate is wrong.
struct Scenario {
  std::vector<Prediction> predictions;
  std::vector<SolverSample> points, lines;
  std::vector<Line3D> line_models;

  Scenario(const Pose& truth, int count, double outlier_share, int candidates, uint32_t seed,
           float noise = 0.005f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.5f, 1.5f), z(1.0f, 4.0f), unit(0, 1);
    std::normal_distribution<float> n(0.0f, noise);
    predictions.resize(count);
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector3f camera(u(rng), u(rng), z(rng));
      const Eigen::Vector3f world =
          (truth.cast<float>() * camera) + Eigen::Vector3f(n(rng), n(rng), n(rng));
      const bool outlier = unit(rng) < outlier_share;
      Prediction& p = predictions[i];
      for (int c = 0; c < candidates; ++c) {
        // Inliers: one candidate right, the others elsewhere (as from other trees).
        const bool right = !outlier && c == 0;
        const Eigen::Vector3f where =
            right ? world : Eigen::Vector3f(u(rng) * 3, u(rng) * 3, u(rng) * 3);
        p.candidates[p.count++] = {isotropicMode(where, 0.02f), 0};
      }
      points.push_back({camera, &predictions[i], nullptr});
    }
  }
};

}  // namespace

TEST(Kabsch, ExactOnNoiselessData) {
  const Pose truth = makePose(71, {0.3, -1, 0.4}, {1.5, -0.2, 0.8});
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<Eigen::Vector3d> camera, world;
  for (int i = 0; i < 3; ++i) {
    camera.emplace_back(u(rng), u(rng), u(rng) + 3);
    world.push_back(truth * camera.back());
  }
  Pose found;
  ASSERT_TRUE(kabsch(camera.data(), world.data(), 3, found));
  EXPECT_LT((found.matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Kabsch, RejectsCollinearPoints) {
  std::vector<Eigen::Vector3d> camera = {{0, 0, 1}, {0, 0, 2}, {0, 0, 3}};
  Pose found;
  EXPECT_FALSE(kabsch(camera.data(), camera.data(), 3, found));
}

namespace {

// A cost function's residual (and, if asked, Jacobian) at perturbation `delta` of `base`.
Eigen::Vector3d evaluateCost(const ceres::CostFunction& cost, const double* delta,
                             Eigen::Matrix<double, 3, 6, Eigen::RowMajor>* jacobian = nullptr) {
  Eigen::Vector3d residual;
  const double* parameters[1] = {delta};
  double* blocks[1] = {jacobian ? jacobian->data() : nullptr};
  EXPECT_TRUE(cost.Evaluate(parameters, residual.data(), jacobian ? blocks : nullptr));
  return residual;
}

const double kZero[6] = {0, 0, 0, 0, 0, 0};

// The autodiff references of the two energies, written straight from their
// definitions (refinement_costs.h) in dual numbers: the hand-derived Jacobians
// are checked against them. `Energy::error` is the unwhitened world-frame
// error at the perturbed pose (r, t).
template <typename Energy>
struct Reference {
  Reference(const RefinementTerm& term, const Pose& base)
      : term(term),
        r0(base.linear()),
        t0(base.translation()),
        s(term.information.llt().matrixL().transpose()) {}
  template <typename T>
  bool operator()(const T* delta, T* residual) const {
    Eigen::Matrix<T, 3, 3> r;
    Eigen::Matrix<T, 3, 1> t;
    perturbedPose(delta, r0, t0, r, t);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> out(residual);
    out = s.cast<T>() * Energy::error(term, r, t);
    return true;
  }
  RefinementTerm term;
  Eigen::Matrix3d r0;
  Eigen::Vector3d t0;
  Eigen::Matrix3d s;  // S^T S = information
};

struct PointToPointEnergy {
  template <typename T>
  static Eigen::Matrix<T, 3, 1> error(const RefinementTerm& term, const Eigen::Matrix<T, 3, 3>& r,
                                      const Eigen::Matrix<T, 3, 1>& t) {
    return r * term.camera_point.cast<T>() + t - term.mode_mean.cast<T>();
  }
};

// E_l in the camera frame: the offset of the mode from the line, rotated back
// to the world to be whitened by the world-frame covariance.
struct PointOnLineEnergy {
  template <typename T>
  static Eigen::Matrix<T, 3, 1> error(const RefinementTerm& term, const Eigen::Matrix<T, 3, 3>& r,
                                      const Eigen::Matrix<T, 3, 1>& t) {
    const Eigen::Matrix<T, 3, 1> offset =
        r.transpose() * (term.mode_mean.cast<T>() - t) - term.line_point.cast<T>();
    const Eigen::Matrix<T, 3, 1> d = term.line_direction.cast<T>();
    return r * (offset - d * d.dot(offset));
  }
};

}  // namespace

TEST(Residuals, PointToPointMatchesHandComputedMahalanobis) {
  const Pose pose = makePose(90, {0, 0, 1}, {1, 0, 0});  // x -> y, then +1 in x
  RefinementTerm term;
  term.camera_point = {1, 0, 0};   // world: (1, 1, 0)
  term.mode_mean = {1, 1.2, 0.3};  // difference (0, -0.2, -0.3)
  term.information = Eigen::Vector3d(1.0 / 0.01, 1.0 / 0.04, 1.0 / 0.09).asDiagonal();
  SharedPerturbation at(pose);
  const Eigen::Vector3d r = evaluateCost(PointToPointCost(term, at), kZero);
  // Each difference over its sigma (0.1, 0.2, 0.3): (0, -1, -1), squared norm 2.
  EXPECT_LT((r - Eigen::Vector3d(0, -1, -1)).cwiseAbs().maxCoeff(), 1e-9) << r.transpose();
  EXPECT_NEAR(r.squaredNorm(), 2.0, 1e-9);
}

TEST(Residuals, PointOnLineMatchesHandComputedDistance) {
  const Pose pose = makePose(90, {0, 0, 1}, {0, 0, 0});  // camera x -> world y
  RefinementTerm term;
  term.on_line = true;
  term.line_point = {0, 0, 2};
  term.line_direction = {0, 1, 0};  // camera y axis through (0, 0, 2): world -x through (0, 0, 2)
  // World (0, 0.1, 2.5) is camera (0.1, 0, 2.5): 0.1 off the line in x, 0.5 in z.
  term.mode_mean = {0, 0.1, 2.5};
  // World-frame covariance: sigma 0.05 along world y (= camera x), 0.25 along z.
  term.information = Eigen::Vector3d(1.0, 1.0 / 0.0025, 1.0 / 0.0625).asDiagonal();
  SharedPerturbation at(pose);
  const PointOnLineCost cost(term, at);
  const Eigen::Vector3d r = evaluateCost(cost, kZero);
  // The world offset (0, 0.1, 0.5) over the world sigmas: (0, 2, 2), squared
  // norm 8: the covariance is rotated into the camera frame.
  EXPECT_LT((r - Eigen::Vector3d(0, 2, 2)).cwiseAbs().maxCoeff(), 1e-9) << r.transpose();
  // Moving along the line changes nothing.
  term.mode_mean = {-0.7, 0.1, 2.5};
  EXPECT_NEAR(evaluateCost(PointOnLineCost(term, at), kZero).squaredNorm(), 8.0, 1e-9);
}

TEST(Residuals, EachTermGetsTheCostOfItsKind) {
  // Kinds interleaved: each cost stays at its term's index.
  std::vector<RefinementTerm> terms(5);
  terms[1].on_line = terms[2].on_line = true;
  SharedPerturbation at(Pose::Identity());
  const TermCosts costs(terms, at);
  ASSERT_EQ(costs.size(), terms.size());
  for (size_t i = 0; i < terms.size(); ++i) {
    if (terms[i].on_line)
      EXPECT_NE(dynamic_cast<PointOnLineCost*>(&costs[i]), nullptr) << i;
    else
      EXPECT_NE(dynamic_cast<PointToPointCost*>(&costs[i]), nullptr) << i;
  }
}

TEST(Residuals, HandDerivedJacobiansMatchAutodiff) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose base =
        makePose(180 * u(rng), {u(rng), u(rng), u(rng) + 2}, {u(rng), u(rng), u(rng)});
    RefinementTerm term;
    term.camera_point = {u(rng), u(rng), 2 + u(rng)};
    term.mode_mean = base * term.camera_point + 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    Eigen::Matrix3d a;
    for (int k = 0; k < 9; ++k) a(k / 3, k % 3) = u(rng);
    term.information = a * a.transpose() + Eigen::Matrix3d::Identity();
    term.on_line = trial % 2 == 1;
    term.line_point = {u(rng), u(rng), 2 + u(rng)};
    term.line_direction = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    // Away from zero too: LM evaluates at accumulated perturbations.
    const double delta[6] = {0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng),
                             0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng)};
    SharedPerturbation at(base);
    Eigen::Matrix<double, 3, 6, Eigen::RowMajor> analytic, autodiff;
    const Eigen::Vector3d residual = evaluateCost(TermCosts({term}, at)[0], delta, &analytic);
    Eigen::Vector3d reference;
    using PointReference = Reference<PointToPointEnergy>;
    using LineReference = Reference<PointOnLineEnergy>;
    if (term.on_line)
      reference = evaluateCost(
          ceres::AutoDiffCostFunction<LineReference, 3, 6>(new LineReference(term, base)), delta,
          &autodiff);
    else
      reference = evaluateCost(
          ceres::AutoDiffCostFunction<PointReference, 3, 6>(new PointReference(term, base)), delta,
          &autodiff);
    EXPECT_LT((residual - reference).norm(), 1e-9);
    EXPECT_LT((analytic - autodiff).cwiseAbs().maxCoeff(),
              1e-8 * (1 + autodiff.cwiseAbs().maxCoeff()))
        << (term.on_line ? "line" : "point") << " term, trial " << trial << "\n"
        << analytic << "\nvs\n"
        << autodiff;
  }
}

std::vector<RefinementTerm> pointTerms(const Scenario& s) {
  std::vector<RefinementTerm> terms;
  for (const auto& sample : s.points) {
    RefinementTerm t;
    t.camera_point = sample.camera_point.cast<double>();
    t.mode_mean = sample.prediction->candidates[0].mode.mean.cast<double>();
    t.information = sample.prediction->candidates[0].mode.informationMatrix().cast<double>();
    terms.push_back(t);
  }
  return terms;
}

TEST(Refinement, LowersTheErrorFromAPerturbedStart) {
  const Pose truth = makePose(25, {1, 2, 3}, {0.4, 1.1, -0.3});
  Scenario s(truth, 400, 0.0, 1, 9);
  const std::vector<RefinementTerm> terms = pointTerms(s);
  const Pose start = truth * makePose(3, {0, 1, 0}, {0.04, -0.03, 0.02});
  const double before = translationError(start, truth);
  const Refinement refined = refinePose(start, terms, PoseSolverParams{});
  ASSERT_TRUE(refined.solved) << refined.message;
  EXPECT_GT(refined.iterations, 0);
  EXPECT_LT(translationError(refined.pose, truth), 0.1 * before);
  EXPECT_LT(translationError(refined.pose, truth), 0.003);
  EXPECT_LT(rotationErrorDegrees(refined.pose, truth), 0.1);
  // Covariance: symmetric, positive, small for 400 good terms.
  const Matrix6d covariance = refinementCovariance(refined.pose, terms, PoseSolverParams{});
  EXPECT_LT((covariance - covariance.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(covariance.diagonal().minCoeff(), 0.0);
  EXPECT_LT(std::sqrt(covariance(0, 0)), 0.01);
}

// refinePose puts every term in one residual block and applies the Cauchy
// loss per term itself; Ceres with a block and a loss per term is the
// reference it must follow step for step.
TEST(Refinement, TakesTheStepsOfAResidualBlockPerTerm) {
  const Pose truth = makePose(25, {1, 2, 3}, {0.4, 1.1, -0.3});
  Scenario s(truth, 300, 0.3, 1, 5);
  std::vector<RefinementTerm> terms = pointTerms(s);
  for (size_t i = 0; i < terms.size(); i += 3) {  // a third on lines through their camera point
    terms[i].on_line = true;
    terms[i].line_direction = Eigen::Vector3d(1, 0.2 * (i % 5), 0.3).normalized();
    terms[i].line_point = terms[i].camera_point - 0.4 * terms[i].line_direction;
  }
  const Pose start = truth * makePose(4, {0, 1, 1}, {0.06, -0.03, 0.04});
  const PoseSolverParams params;
  for (int iterations : {params.lm_loop_iterations, params.lm_iterations}) {
    SharedPerturbation at(start);
    const TermCosts costs(terms, at);
    ceres::CauchyLoss loss(params.robust_scale);
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    double delta[6] = {0, 0, 0, 0, 0, 0};
    for (size_t i = 0; i < costs.size(); ++i) problem.AddResidualBlock(&costs[i], &loss, delta);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
    options.max_num_iterations = iterations;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    Eigen::Matrix3d r;
    Eigen::Vector3d t;
    perturbedPose(delta, start.linear(), start.translation(), r, t);

    const Refinement refined = refinePose(start, terms, params, iterations);
    ASSERT_TRUE(refined.solved) << refined.message;
    EXPECT_EQ(refined.iterations, summary.num_successful_steps + summary.num_unsuccessful_steps);
    EXPECT_LT((refined.pose.translation() - t).norm(), 1e-9) << iterations << " iterations";
    EXPECT_LT((refined.pose.linear() - nearestRotation(r)).norm(), 1e-9);
    // And the steps went somewhere: most of the start's error is gone.
    EXPECT_LT(translationError(refined.pose, truth), 0.3 * translationError(start, truth));
  }
}

TEST(Refinement, AnUnusableSolveKeepsTheStartAndSaysWhy) {
  const Pose truth = makePose(25, {1, 2, 3}, {0.4, 1.1, -0.3});
  Scenario s(truth, 50, 0.0, 1, 9);
  std::vector<RefinementTerm> terms = pointTerms(s);
  // One term with a non-finite mode: the initial cost is not finite, and Ceres
  // gives up before its first step.
  terms[7].mode_mean.x() = std::numeric_limits<double>::quiet_NaN();
  const Pose start = truth * makePose(3, {0, 1, 0}, {0.04, -0.03, 0.02});
  const Refinement refined = refinePose(start, terms, PoseSolverParams{});
  EXPECT_FALSE(refined.solved);
  EXPECT_EQ(refined.pose.matrix(), start.matrix());  // bit for bit, not re-orthonormalised
  EXPECT_NE(refined.message.find("Ceres"), std::string::npos) << refined.message;

  const Refinement too_few = refinePose(start, {terms[0], terms[1]}, PoseSolverParams{});
  EXPECT_FALSE(too_few.solved);
  EXPECT_EQ(too_few.pose.matrix(), start.matrix());
  EXPECT_EQ(refinementCovariance(start, {terms[0], terms[1]}, PoseSolverParams{}),
            Matrix6d::Identity());
}

TEST(Ransac, RecoversAKnownPoseWithSixtyPercentOutliers) {
  const Pose truth = makePose(40, {0.2, 1, -0.3}, {2.0, -1.0, 0.5});
  Scenario s(truth, 1500, 0.6, 3, 17);
  std::mt19937 rng(1);
  const PoseSolution solution = solvePose(s.points, s.lines, PoseSolverParams{}, rng);
  ASSERT_TRUE(solution.success) << solution.message;
  EXPECT_LT(translationError(solution.pose, truth), 0.01);
  EXPECT_LT(rotationErrorDegrees(solution.pose, truth), 0.5);
  EXPECT_NEAR(solution.point_inliers, 1500 * 0.4, 80);
  EXPECT_EQ(solution.failed_refinements, 0) << solution.refinement_failure;
}

TEST(Ransac, WeakEvidenceGivesAFailureNotAPose) {
  // 8% of the samples agree on a pose: it is found, but the evidence is under
  // the 15% inlier share the solver needs, so the answer is "no pose".
  const Pose truth = makePose(10, {0, 0, 1}, {0, 0, 0});
  Scenario s(truth, 1000, 0.92, 3, 23);
  std::mt19937 rng(1);
  const PoseSolution solution = solvePose(s.points, s.lines, PoseSolverParams{}, rng);
  EXPECT_FALSE(solution.success);
  EXPECT_NE(solution.message.find("weak evidence"), std::string::npos) << solution.message;
  EXPECT_LT(solution.score, 0.15f);
}

TEST(Ransac, PureNoiseGivesAFailure) {
  const Pose truth = makePose(10, {0, 0, 1}, {0, 0, 0});
  for (uint32_t seed : {23u, 24u, 25u}) {
    Scenario s(truth, 600, 1.0, 3, seed);
    std::mt19937 rng(seed);
    const PoseSolution solution = solvePose(s.points, s.lines, PoseSolverParams{}, rng);
    EXPECT_FALSE(solution.success) << "seed " << seed;
    EXPECT_FALSE(solution.message.empty());
  }
}

TEST(Screen, FindsTheTruthWhereFewMinimalSetsAreRigid) {
  // 200 samples with one candidate each, 92 % of them wrong: about one
  // minimal set in 2000 is all right (rigid). The full solve's draw budget (32
  // hypotheses x 20 sets) often finds no rigid set at all and screens 0
  // inliers at the identity (measured: the truth on 4 of 10); the screen's
  // own budget (64 x 80) finds the truth (9 of 10).
  const Pose truth = makePose(30, {0.3, 1, 0.2}, {1.5, -0.5, 0.8});
  const ScreenParams screen;
  int found = 0, found_with_solver_budget = 0;
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    Scenario s(truth, 200, 0.92, 1, 100 + seed);
    auto near = [&](const ScreenResult& r) {
      return r.inliers >= 10 && translationError(r.pose, truth) < 0.05 &&
             rotationErrorDegrees(r.pose, truth) < 2.0;
    };
    std::mt19937 rng(seed), old_rng(seed);
    found += near(
        screenPose(s.points, PoseSolverParams{}, screen.hypotheses, screen.sampling_attempts, rng));
    found_with_solver_budget += near(screenPose(s.points, PoseSolverParams{}, 32,
                                                PoseSolverParams{}.max_sampling_attempts, old_rng));
  }
  std::printf("truth screened on %d of 10 frames (%d with the full solve's draw budget)\n", found,
              found_with_solver_budget);
  EXPECT_GE(found, 8);
  EXPECT_LE(found_with_solver_budget, found - 3);
}

TEST(Ransac, TooFewPredictionsIsAnExplicitFailure) {
  Scenario s(Pose::Identity(), 2, 0.0, 1, 3);
  std::mt19937 rng(1);
  const PoseSolution solution = solvePose(s.points, s.lines, PoseSolverParams{}, rng);
  EXPECT_FALSE(solution.success);
  EXPECT_NE(solution.message.find("too few point predictions"), std::string::npos);
}

namespace {

using LaneKernel = void (*)(const LanePoses&, const LaneSample*, size_t, const LaneMode*, float,
                            LaneSums&);

// Every build of scoreLanes this CPU can run, with its name.
std::vector<std::pair<const char*, LaneKernel>> laneKernels() {
  std::vector<std::pair<const char*, LaneKernel>> kernels = {{"portable", scoreLanesPortable},
                                                             {"dispatched", scoreLanes}};
  if (lanesHaveAvx2()) kernels.push_back({"avx2", scoreLanesAvx2});
  return kernels;
}

void setLane(LanePoses& poses, int lane, const Eigen::Matrix3f& r, const Eigen::Vector3f& t) {
  for (int k = 0; k < 9; ++k) poses.rotation[k][lane] = r(k / 3, k % 3);
  for (int k = 0; k < 3; ++k) poses.translation[k][lane] = t(k);
}

LaneMode laneMode(float x, float y, float z, float xy = 0.0f) {
  return {{x, y, z}, {1.0f, xy, 0.0f, 1.0f, 0.0f, 1.0f}};
}

LaneSums zeroSums() {
  LaneSums sums;
  std::memset(&sums, 0, sizeof sums);
  return sums;
}

// Lane `l` of `sums` equals `expected` and `score`, bit for bit.
void expectLane(const LaneSums& sums, int l, const AlignmentSums& expected, int score,
                const std::string& what) {
  EXPECT_EQ(sums.score[l], score) << what;
  EXPECT_EQ(sums.count[l], expected.count) << what;
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(sums.source[k][l], expected.source(k)) << what;
    EXPECT_EQ(sums.target[k][l], expected.target(k)) << what;
  }
  for (int k = 0; k < 9; ++k) EXPECT_EQ(sums.cross[k][l], expected.cross(k / 3, k % 3)) << what;
}

}  // namespace

// Distances chosen exactly representable, so every comparison is exact: lane l
// sits at x = l / 4 (lane 7 is rotated a quarter turn about z instead), chi2 =
// 1/4 under unit information.
TEST(LaneScoring, EachLaneAddsItsNearestModeUnderChi2) {
  LanePoses poses;
  for (int l = 0; l < 7; ++l)
    setLane(poses, l, Eigen::Matrix3f::Identity(), Eigen::Vector3f(0.25f * l, 0, 0));
  setLane(poses, 7, Eigen::AngleAxisf(M_PI / 2, Eigen::Vector3f::UnitZ()).toRotationMatrix(),
          Eigen::Vector3f::Zero());
  const std::vector<LaneSample> samples = {
      {{0, 0, 1}, 2, 0},     // modes 0 and 1 on the lanes' line
      {{0.5f, 0, 1}, 1, 1},  // mode 2, reached by lane 7's rotation only
      {{10, 10, 10}, 1, 2},  // mode 3, far from every lane
      {{0, 0, 1}, 1, 3}};    // mode 4, whose information couples x and y
  const std::vector<LaneMode> modes = {laneMode(0.5f, 0, 1), laneMode(1.25f, 0, 1),
                                       laneMode(0, 0.5f, 1), laneMode(0, 0, 0),
                                       laneMode(0.375f, 0.375f, 1, -0.5f)};
  // The mode each lane takes per sample (-1: none). Lane 0 of sample 0 is
  // exactly chi2 from mode 0 (not an inlier), lane 3 as near to both modes
  // (the first wins); the coupled information of mode 4 makes lanes 0-2
  // inliers that unit information would reject for lane 0.
  const int chosen[4][kScoreLanes] = {{-1, 0, 0, 0, 1, 1, 1, -1},
                                      {-1, -1, -1, -1, -1, -1, -1, 2},
                                      {-1, -1, -1, -1, -1, -1, -1, -1},
                                      {4, 4, 4, -1, -1, -1, -1, 4}};
  for (const auto& [name, kernel] : laneKernels()) {
    LaneSums sums = zeroSums();
    // Lane 5 starts from earlier rounds' sums, which it must keep adding to.
    AlignmentSums earlier;
    earlier.add({1, 2, 3}, {4, 5, 6});
    sums.score[5] = 7;
    sums.count[5] = earlier.count;
    for (int k = 0; k < 3; ++k) sums.source[k][5] = earlier.source(k);
    for (int k = 0; k < 3; ++k) sums.target[k][5] = earlier.target(k);
    for (int k = 0; k < 9; ++k) sums.cross[k][5] = earlier.cross(k / 3, k % 3);
    kernel(poses, samples.data(), samples.size(), modes.data(), 0.25f, sums);
    for (int l = 0; l < kScoreLanes; ++l) {
      AlignmentSums expected = l == 5 ? earlier : AlignmentSums{};
      int score = l == 5 ? 7 : 0;
      for (int i = 0; i < 4; ++i) {
        if (chosen[i][l] < 0) continue;
        const LaneMode& m = modes[chosen[i][l]];
        const LaneSample& c = samples[i];
        expected.add(Eigen::Vector3d(c.camera[0], c.camera[1], c.camera[2]),
                     Eigen::Vector3d(m.mean[0], m.mean[1], m.mean[2]));
        ++score;
      }
      expectLane(sums, l, expected, score, std::string(name) + " lane " + std::to_string(l));
    }
  }
}

// The AVX2 build against the portable one on a random batch like a real
// round's: the same sums, bit for bit, also where distances are near chi2.
TEST(LaneScoring, EveryBuildMatchesThePortableOne) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f), unit(0.0f, 1.0f);
  LanePoses poses;
  for (int l = 0; l < kScoreLanes; ++l)
    setLane(poses, l,
            Eigen::AngleAxisf(u(rng), Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized())
                .toRotationMatrix(),
            Eigen::Vector3f(u(rng), u(rng), u(rng)) * 0.1f);
  std::vector<LaneSample> samples;
  std::vector<LaneMode> modes;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3f camera(u(rng), u(rng), 1.0f + unit(rng) * 3.0f);
    const int count = 1 + static_cast<int>(unit(rng) * 5) % 5;
    samples.push_back({{camera.x(), camera.y(), camera.z()}, count, i});
    // Near some lane's image of the camera point, with an anisotropic
    // information matrix (A A^T + I, positive definite).
    const int lane = static_cast<int>(unit(rng) * kScoreLanes) % kScoreLanes;
    Eigen::Matrix3f r;
    Eigen::Vector3f t;
    for (int k = 0; k < 9; ++k) r(k / 3, k % 3) = poses.rotation[k][lane];
    for (int k = 0; k < 3; ++k) t(k) = poses.translation[k][lane];
    const Eigen::Vector3f world = r * camera + t;
    for (int c = 0; c < count; ++c) {
      Eigen::Matrix3f a;
      for (int k = 0; k < 9; ++k) a(k / 3, k % 3) = u(rng);
      const Eigen::Matrix3f info = (a * a.transpose() + Eigen::Matrix3f::Identity()) * 25.0f;
      const Eigen::Vector3f mean = world + Eigen::Vector3f(u(rng), u(rng), u(rng)) * 0.2f;
      modes.push_back({{mean.x(), mean.y(), mean.z()},
                       {info(0, 0), info(0, 1), info(0, 2), info(1, 1), info(1, 2), info(2, 2)}});
    }
  }
  LaneSums reference = zeroSums();
  scoreLanesPortable(poses, samples.data(), samples.size(), modes.data(), 9.0f, reference);
  // A test that can fail either way: every lane has inliers, none has all.
  for (int l = 0; l < kScoreLanes; ++l) {
    EXPECT_GT(reference.score[l], 20) << "lane " << l;
    EXPECT_LT(reference.score[l], 2000) << "lane " << l;
  }
  if (!lanesHaveAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable build runs";
  for (const auto& [name, kernel] : laneKernels()) {
    LaneSums sums = zeroSums();
    kernel(poses, samples.data(), samples.size(), modes.data(), 9.0f, sums);
    EXPECT_EQ(std::memcmp(&sums, &reference, sizeof sums), 0) << name;
  }
}
