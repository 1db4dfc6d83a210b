#include "relocalizer/pose/pose_solver.h"

#include <tbb/parallel_for.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <limits>
#include <numeric>
#include <optional>

#include "relocalizer/core/rigid_alignment.h"
#include "relocalizer/pose/lane_scoring.h"
#include "relocalizer/pose/refinement.h"

namespace relocalizer {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A batch's samples (LaneSample) and, after each, its candidate modes
// (LaneMode), copied contiguously so that scoring hundreds of hypotheses reads
// a compact block instead of chasing pointers.

struct Hypothesis {
  Pose pose;
  Eigen::Matrix3f rotation;
  Eigen::Vector3f translation;
  int score = 0;          // inliers accumulated over rounds
  double rank = 0;        // score weighed by the hint, when there is one
  AlignmentSums inliers;  // camera point -> mode mean of those inliers, for Kabsch refits
  int index = 0;

  void setPose(const Pose& p) {
    pose = p;
    rotation = p.linear().cast<float>();
    translation = p.translation().cast<float>();
  }
};

// Scores up to kScoreLanes hypotheses at once on a batch (scoreLanes, where
// preemptive RANSAC spends its time): a sample is an inlier of a lane when a
// candidate lies within `chi2`, and the lane's score and Kabsch statistics take
// the nearest one, in batch order.
void scoreBlock(Hypothesis* block, int count, const std::vector<LaneSample>& batch,
                const std::vector<LaneMode>& batch_modes, float chi2) {
  LanePoses poses;
  LaneSums sums;
  for (int l = 0; l < kScoreLanes; ++l) {
    // Unused lanes repeat the first hypothesis; their results are dropped.
    const Hypothesis& h = block[l < count ? l : 0];
    for (int k = 0; k < 9; ++k) poses.rotation[k][l] = h.rotation(k / 3, k % 3);
    for (int k = 0; k < 3; ++k) poses.translation[k][l] = h.translation(k);
    const AlignmentSums& in = h.inliers;
    sums.score[l] = h.score;
    sums.count[l] = in.count;
    for (int k = 0; k < 3; ++k) sums.source[k][l] = in.source(k);
    for (int k = 0; k < 3; ++k) sums.target[k][l] = in.target(k);
    for (int k = 0; k < 9; ++k) sums.cross[k][l] = in.cross(k / 3, k % 3);
  }
  scoreLanes(poses, batch.data(), batch.size(), batch_modes.data(), chi2, sums);
  for (int l = 0; l < count; ++l) {
    Hypothesis& h = block[l];
    AlignmentSums& out = h.inliers;
    h.score = sums.score[l];
    out.count = sums.count[l];
    for (int k = 0; k < 3; ++k) out.source(k) = sums.source[k][l];
    for (int k = 0; k < 3; ++k) out.target(k) = sums.target[k][l];
    for (int k = 0; k < 9; ++k) out.cross(k / 3, k % 3) = sums.cross[k][l];
  }
}

// Index of the candidate mode that best explains `world`, and its distance.
inline int bestMode(const Prediction& prediction, const Eigen::Vector3f& world, float& best) {
  int chosen = -1;
  best = std::numeric_limits<float>::max();
  for (int c = 0; c < prediction.count; ++c) {
    const LeafMode& m = prediction.candidates[c].mode;
    const float e = m.mahalanobisSquared(world);
    if (e < best) {
      best = e;
      chosen = c;
    }
  }
  return chosen;
}

Eigen::Matrix3d informationOf(const LeafMode& mode) {
  return mode.informationMatrix().cast<double>();
}

// Refinement terms for every sample that is an inlier of `pose`; with
// `solution`, its inlier counts and camera points too.
void collectTerms(const std::vector<const SolverSample*>& samples, const Pose& pose,
                  const PoseSolverParams& params, std::vector<RefinementTerm>& terms,
                  int* point_inliers, int* line_inliers, PoseSolution* solution = nullptr) {
  terms.clear();
  terms.reserve(samples.size());  // at most one term per sample: no regrowth
  int points = 0, lines = 0;
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  for (const SolverSample* s : samples) {
    float distance = 0;
    const int c = bestMode(*s->prediction, r * s->camera_point + t, distance);
    if (c < 0 || distance >= params.inlier_chi2) continue;
    const LeafMode& mode = s->prediction->candidates[c].mode;
    RefinementTerm term;
    term.camera_point = s->camera_point.cast<double>();
    term.mode_mean = mode.mean.cast<double>();
    term.information = informationOf(mode);
    if (solution)
      (s->line ? solution->line_inlier_cameras : solution->point_inlier_cameras)
          .push_back(s->camera_point);
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

// Samples with at least one candidate mode, points first; the first
// `point_count` are point samples, which alone seed hypotheses.
std::vector<const SolverSample*> usableSamples(const std::vector<SolverSample>& points,
                                               const std::vector<SolverSample>& lines,
                                               int& point_count) {
  std::vector<const SolverSample*> all;
  for (const auto& s : points)
    if (s.prediction && s.prediction->count > 0) all.push_back(&s);
  point_count = static_cast<int>(all.size());
  for (const auto& s : lines)
    if (s.prediction && s.prediction->count > 0 && s.line) all.push_back(&s);
  return all;
}

// A minimal set worth a Kabsch solve: camera points far enough apart, world
// modes at the same mutual distances (a rigid motion keeps them), and not
// nearly collinear (which leaves the rotation about their line undetermined).
bool plausibleMinimalSet(const Eigen::Vector3d (&camera)[3], const Eigen::Vector3d (&world)[3],
                         const PoseSolverParams& params) {
  const float min_d2 = params.min_point_distance * params.min_point_distance;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3;
    const double dc = (camera[a] - camera[b]).norm(), dw = (world[a] - world[b]).norm();
    if (dc * dc < min_d2) return false;
    const double tolerance =
        std::max<double>(params.rigidity_tolerance, params.rigidity_ratio * dc);
    if (std::abs(dc - dw) > tolerance) return false;
  }
  return !((camera[1] - camera[0]).cross(camera[2] - camera[0]).norm() < 0.5 * min_d2);
}

// Up to params.hypotheses poses, each by Kabsch from three point samples with
// a random candidate mode each; `attempts` minimal sets at most.
std::vector<Hypothesis> drawHypotheses(const std::vector<const SolverSample*>& all, int point_count,
                                       const PoseSolverParams& params, int attempts,
                                       std::mt19937& rng) {
  std::vector<Hypothesis> hypotheses;
  hypotheses.reserve(params.hypotheses);
  // The candidates' modes are unpacked into the predictions (forest.h), which
  // the forests wrote just now: no read here reaches into the model.
  std::uniform_int_distribution<int> pick_point(0, point_count - 1);
  for (int attempt = 0;
       attempt < attempts && static_cast<int>(hypotheses.size()) < params.hypotheses; ++attempt) {
    const int i0 = pick_point(rng), i1 = pick_point(rng), i2 = pick_point(rng);
    if (i0 == i1 || i0 == i2 || i1 == i2) continue;
    const SolverSample* s[3] = {all[i0], all[i1], all[i2]};
    Eigen::Vector3d camera[3], world[3];
    for (int k = 0; k < 3; ++k) {
      std::uniform_int_distribution<int> pick_mode(0, s[k]->prediction->count - 1);
      camera[k] = s[k]->camera_point.cast<double>();
      world[k] = s[k]->prediction->candidates[pick_mode(rng)].mode.mean.cast<double>();
    }
    if (!plausibleMinimalSet(camera, world, params)) continue;
    Pose pose;
    if (!kabsch(camera, world, 3, pose)) continue;
    Hypothesis h;
    h.setPose(pose);
    h.index = static_cast<int>(hypotheses.size());
    hypotheses.push_back(h);
  }
  return hypotheses;
}

// The preemptive rounds: each scores the surviving hypotheses on a fresh batch
// of samples, keeps the better half and refines it, until one is left.
class PreemptiveRounds {
 public:
  PreemptiveRounds(const std::vector<const SolverSample*>& all, const PoseSolverParams& params,
                   std::mt19937& rng, const HintPrior* hint = nullptr)
      : all_(all), params_(params), hint_(hint), order_(all.size()) {
    std::iota(order_.begin(), order_.end(), 0);
    std::shuffle(order_.begin(), order_.end(), rng);
  }

  // LM solves so far that Ceres called unusable.
  int failedRefinements() const { return failed_refinements_; }

  // The winner; `lm_seconds` receives the time spent in LM refinement.
  Pose run(std::vector<Hypothesis>& hypotheses, double& lm_seconds) {
    lm_seconds = 0.0;
    while (true) {
      nextBatch();
      score(hypotheses);
      if (hypotheses.size() == 1) break;
      hypotheses.resize((hypotheses.size() + 1) / 2);
      if (static_cast<int>(hypotheses.size()) > params_.lm_hypotheses) {
        refitByKabsch(hypotheses);
      } else {
        const auto lm_start = Clock::now();
        refineByLm(hypotheses);
        lm_seconds += secondsSince(lm_start);
      }
    }
    return hypotheses.front().pose;
  }

 private:
  // The next batch_size samples of the shuffled pool, wrapping round when the
  // pool is exhausted (the same samples are then scored again).
  void nextBatch() {
    batch_.clear();
    batch_modes_.clear();
    const int batch_size = std::max(1, params_.batch_size);
    for (int k = 0; k < batch_size && k < static_cast<int>(all_.size()); ++k) {
      if (next_sample_ == order_.size()) next_sample_ = 0;
      const int index = order_[next_sample_++];
      const SolverSample& s = *all_[index];
      const Eigen::Vector3f& p = s.camera_point;
      batch_.push_back({{p.x(), p.y(), p.z()}, s.prediction->count, index});
      for (int c = 0; c < s.prediction->count; ++c) {
        const LeafMode& m = s.prediction->candidates[c].mode;
        const auto& in = m.information;
        batch_modes_.push_back(
            {{m.mean.x(), m.mean.y(), m.mean.z()}, {in[0], in[1], in[2], in[3], in[4], in[5]}});
      }
    }
  }

  // Adds the batch's inliers to every hypothesis and sorts them best first
  // (ties by creation order, so the outcome never depends on threads); with
  // a hint, by their inliers weighed by it.
  void score(std::vector<Hypothesis>& hypotheses) const {
    const size_t lanes = kScoreLanes;
    const size_t blocks = (hypotheses.size() + lanes - 1) / lanes;
    tbb::parallel_for(size_t{0}, blocks, [&](size_t b) {
      scoreBlock(hypotheses.data() + b * lanes,
                 static_cast<int>(std::min(lanes, hypotheses.size() - b * lanes)), batch_,
                 batch_modes_, params_.inlier_chi2);
    });
    // Without a hint the rank is the score itself (an int, exact as a double).
    for (Hypothesis& h : hypotheses)
      h.rank = hint_ ? h.score * hint_->factor(h.pose, params_.hint_weight) : h.score;
    std::sort(hypotheses.begin(), hypotheses.end(), [](const Hypothesis& a, const Hypothesis& b) {
      return a.rank != b.rank ? a.rank > b.rank : a.index < b.index;
    });
  }

  // Many hypotheses left: a Kabsch refit on the inliers gathered so far.
  void refitByKabsch(std::vector<Hypothesis>& hypotheses) const {
    tbb::parallel_for(size_t{0}, hypotheses.size(), [&](size_t h) {
      Hypothesis& hyp = hypotheses[h];
      Pose refit;
      if (kabsch(hyp.inliers, refit)) hyp.setPose(refit);
    });
  }

  // Few left: Levenberg-Marquardt on this round's inliers, in parallel. A
  // hypothesis whose solve fails keeps its pose.
  void refineByLm(std::vector<Hypothesis>& hypotheses) {
    seen_.clear();
    for (const LaneSample& e : batch_) seen_.push_back(all_[e.sample]);
    // One term buffer per hypothesis, kept across rounds: each keeps its
    // capacity, so later rounds allocate nothing.
    if (lm_terms_.size() < hypotheses.size()) lm_terms_.resize(hypotheses.size());
    std::atomic<int> failed{0};
    tbb::parallel_for(size_t{0}, hypotheses.size(), [&](size_t h) {
      Hypothesis& hyp = hypotheses[h];
      std::vector<RefinementTerm>& terms = lm_terms_[h];
      collectTerms(seen_, hyp.pose, params_, terms, nullptr, nullptr);
      if (terms.size() < 3) return;
      const Refinement refined = refinePose(hyp.pose, terms, params_, params_.lm_loop_iterations);
      if (refined.solved)
        hyp.setPose(refined.pose);
      else
        ++failed;
    });
    failed_refinements_ += failed;
  }

  const std::vector<const SolverSample*>& all_;
  const PoseSolverParams& params_;
  const HintPrior* hint_;
  std::vector<int> order_;
  size_t next_sample_ = 0;
  std::vector<LaneSample> batch_;
  std::vector<LaneMode> batch_modes_;
  std::vector<const SolverSample*> seen_;
  std::vector<std::vector<RefinementTerm>> lm_terms_;
  int failed_refinements_ = 0;
};

// The winner refined on all samples: two LM passes (its inlier set grows as
// it improves), then its inlier counts and covariance at the pose it answers
// with. A failed pass keeps the pose it started from.
void refineOnAllSamples(const std::vector<const SolverSample*>& all, const Pose& winner,
                        const PoseSolverParams& params, PoseSolution& solution) {
  std::vector<RefinementTerm> terms;
  Pose pose = winner;
  for (int pass = 0; pass < 2; ++pass) {
    collectTerms(all, pose, params, terms, nullptr, nullptr);
    if (terms.size() < 3) break;
    const Refinement refined = refinePose(pose, terms, params);
    pose = refined.pose;
    if (!refined.solved) {
      ++solution.failed_refinements;
      solution.refinement_failure = refined.message;
    }
  }
  solution.point_inlier_cameras.clear();
  solution.line_inlier_cameras.clear();
  collectTerms(all, pose, params, terms, &solution.point_inliers, &solution.line_inliers,
               &solution);
  solution.covariance = refinementCovariance(pose, terms, params);
  solution.pose = pose;
}

// Answers with the pose only when its inliers clear both evidence thresholds.
void judgeEvidence(size_t samples, const PoseSolverParams& params, PoseSolution& solution) {
  const int inliers = solution.point_inliers + solution.line_inliers;
  solution.score = samples == 0 ? 0.0f : static_cast<float>(inliers) / samples;
  if (inliers < params.min_inliers || solution.score < params.min_inlier_ratio) {
    char buffer[200];
    std::snprintf(buffer, sizeof buffer,
                  "weak evidence: %d inliers (%.1f%% of %zu samples); need %d and %.1f%%", inliers,
                  100.0 * solution.score, samples, params.min_inliers,
                  100.0 * params.min_inlier_ratio);
    solution.message = buffer;
    return;
  }
  solution.success = true;
}

}  // namespace

PoseSolution solvePose(const std::vector<SolverSample>& points,
                       const std::vector<SolverSample>& lines, const PoseSolverParams& params,
                       std::mt19937& rng, const PoseHint* pose_hint) {
  PoseSolution solution;
  std::optional<HintPrior> prior;
  if (pose_hint) {
    Expected<HintPrior> made = HintPrior::make(*pose_hint);
    if (!made) {
      solution.message = "unusable pose hint: " + made.error();
      return solution;
    }
    prior = *made;
  }
  const HintPrior* hint = prior ? &*prior : nullptr;
  const auto ransac_start = Clock::now();
  int point_count = 0;
  const std::vector<const SolverSample*> all = usableSamples(points, lines, point_count);
  solution.samples = static_cast<int>(all.size());
  if (point_count < 3) {
    solution.message = "too few point predictions for a pose (" + std::to_string(point_count) +
                       "; need at least 3)";
    return solution;
  }

  const int attempts = params.hypotheses * std::max(1, params.max_sampling_attempts);
  std::vector<Hypothesis> hypotheses = drawHypotheses(all, point_count, params, attempts, rng);
  solution.valid_hypotheses = static_cast<int>(hypotheses.size());
  if (hypotheses.empty()) {
    solution.message = "no pose hypothesis passed the rigidity checks (" +
                       std::to_string(attempts) + " minimal sets tried)";
    solution.ransac_seconds = secondsSince(ransac_start);
    return solution;
  }
  if (hint && hint->complete()) {
    // Appended after the draws: the random stream is that of a solve without a hint.
    Hypothesis seeded;
    seeded.setPose(hint->pose());
    seeded.index = static_cast<int>(hypotheses.size());
    hypotheses.push_back(seeded);
  }

  double lm_seconds = 0.0;
  PreemptiveRounds rounds(all, params, rng, hint);
  const Pose winner = rounds.run(hypotheses, lm_seconds);
  solution.failed_refinements = rounds.failedRefinements();
  solution.ransac_seconds = secondsSince(ransac_start) - lm_seconds;

  const auto refine_start = Clock::now();
  refineOnAllSamples(all, winner, params, solution);
  solution.refinement_seconds = lm_seconds + secondsSince(refine_start);
  judgeEvidence(all.size(), params, solution);
  return solution;
}

ScreenResult screenPose(const std::vector<SolverSample>& points, const PoseSolverParams& params,
                        int hypotheses, int sampling_attempts, std::mt19937& rng) {
  int point_count = 0;
  const std::vector<const SolverSample*> all = usableSamples(points, {}, point_count);
  if (point_count < 3 || hypotheses < 1) return {};
  PoseSolverParams screen = params;
  screen.hypotheses = hypotheses;
  // Every round scores on all samples, and Kabsch refits replace LM throughout.
  screen.batch_size = point_count;
  screen.lm_hypotheses = 0;
  const int attempts = hypotheses * std::max(1, sampling_attempts);
  std::vector<Hypothesis> drawn = drawHypotheses(all, point_count, screen, attempts, rng);
  if (drawn.empty()) return {};
  PreemptiveRounds rounds(all, screen, rng);
  double lm_seconds = 0.0;
  const Pose winner = rounds.run(drawn, lm_seconds);
  std::vector<RefinementTerm> terms;
  ScreenResult result;
  result.pose = winner;
  collectTerms(all, winner, screen, terms, &result.inliers, nullptr);
  return result;
}

}  // namespace relocalizer
