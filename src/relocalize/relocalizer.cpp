#include "relocalizer/relocalize/relocalizer.h"

#include <tbb/task_group.h>

#include <chrono>
#include <cstdio>
#include <utility>

#include "relocalizer/relocalize/light_retry.h"
#include "relocalizer/relocalize/second_draw.h"

namespace relocalizer {

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}
std::vector<Eigen::Vector3f> inWorld(const Pose& camera_to_world,
                                     const std::vector<Eigen::Vector3f>& camera_points) {
  const Eigen::Isometry3f pose = camera_to_world.cast<float>();
  std::vector<Eigen::Vector3f> world;
  world.reserve(camera_points.size());
  for (const Eigen::Vector3f& p : camera_points) world.push_back(pose * p);
  return world;
}
}  // namespace

Relocalizer::Relocalizer(Model model, RelocalizerParams params)
    : model_(std::move(model)), params_(std::move(params)) {}

Expected<std::unique_ptr<Relocalizer>> Relocalizer::fromFile(const std::string& model_path,
                                                             const RelocalizerParams& params) {
  auto model = loadModel(model_path);
  if (!model) return makeError(model.error());
  auto relocalizer = std::make_unique<Relocalizer>(std::move(*model), params);
  const std::string why = relocalizer->validationError();
  if (!why.empty()) return makeError(model_path + ": " + why);
  return relocalizer;
}

std::string Relocalizer::validationError() const {
  const bool points = params_.use_points && !model_.points.empty();
  const bool lines = params_.use_lines && !model_.lines.empty();
  if (!points && !lines)
    return "the model has no forest that the parameters allow (use_points=" +
           std::to_string(params_.use_points) + ", use_lines=" + std::to_string(params_.use_lines) +
           ", point trees=" + std::to_string(model_.points.trees.size()) +
           ", line trees=" + std::to_string(model_.lines.trees.size()) + ")";
  if (params_.point_samples < 0 || params_.line_samples < 0 || params_.max_leaves < 1)
    return "point_samples and line_samples must be >= 0 and max_leaves >= 1";
  if (!(params_.light_retry_min_cast >= 0))
    return "light_retry_min_cast must be >= 0 (0 = never ask again in the training light)";
  if (!(params_.confirm_below >= 0 && params_.confirm_below <= 1))
    return "confirm_below must be an inlier share between 0 and 1 (0 = never draw again)";
  if (params_.solver.hypotheses < 1 || params_.solver.batch_size < 1)
    return "solver.hypotheses and solver.batch_size must be >= 1";
  if (!(params_.solver.hint_weight >= 0 && params_.solver.hint_weight <= 1))
    return "solver.hint_weight must be a share between 0 and 1";
  if (const std::string missing = lineDetectorMissing(model_.params.line_sampling.line_detector);
      lines && !missing.empty())
    return "the model's line forest was trained with " + missing +
           "; relocalize with the point forest alone (use_lines: false) or retrain the model "
           "(the default line detector is our own)";
  const SurfaceFitParams& s = params_.surface;
  if (s.points < 1 || s.iterations < 0 || s.min_correspondences < 0)
    return "surface.points must be >= 1, surface.iterations and surface.min_correspondences >= 0";
  if (!(s.max_distance > 0 && s.huber > 0 && s.tolerance > 0))
    return "surface.max_distance, surface.huber and surface.tolerance must be positive (metres)";
  if (!(s.min_agreement >= 0 && s.min_agreement <= 1 && s.min_on_surface >= 0 &&
        s.min_on_surface <= 1 && s.max_seen_through >= 0 && s.max_seen_through <= 1))
    return "surface.min_agreement, surface.min_on_surface and surface.max_seen_through must be "
           "shares between 0 and 1";
  if (!(s.occlusion_margin > 0 && s.occlusion_reach > 0))
    return "surface.occlusion_margin and surface.occlusion_reach must be positive (metres)";
  return {};
}

namespace {

struct ForestPredictions {
  std::vector<Prediction> points, lines;
};

bool usesPoints(const Model& model, const RelocalizerParams& params) {
  return params.use_points && !model.points.empty();
}
bool usesLines(const Model& model, const RelocalizerParams& params) {
  return params.use_lines && !model.lines.empty();
}

// The frame as the forests see it: its colour as the model's training saw colour
// (the same pixels when the model normalises none).
RgbdFrame asTrainingSaw(const RgbdFrame& recorded, const Model& model) {
  RgbdFrame frame = recorded;
  frame.colour = normaliseColour(recorded.colour, model.params.colour_normalisation);
  return frame;
}

// Draws the frame's samples and their descriptors in two branches that share
// nothing but the frame: random pixels, and LSD -> line samples. LSD runs on
// one core whatever the thread count, so with two or more threads it overlaps
// the point branch instead of leaving a core idle; with one thread the
// branches run one after the other. With `predictions` each branch also runs
// its forest at once, so LSD overlaps the point forest too. The point samples
// are drawn first and the line branch has its own random stream forked from
// the seed, so the answer does not depend on which branch runs first.
void sampleFrame(const Model& model, const RelocalizerParams& params, const RgbdFrame& recorded,
                 FrameSamples& samples, ForestPredictions* predictions, StageTimings& timings,
                 const std::function<void(const FrameSamples&)>* points_ready = nullptr) {
  const RgbdFrame frame = asTrainingSaw(recorded, model);
  samples.colour = frame.colour;
  const bool use_points = usesPoints(model, params), use_lines = usesLines(model, params);
  samples.rng.seed(params.seed);
  auto stage = Clock::now();
  if (use_points) samplePoints(frame, params.point_samples, samples.rng, samples.points);
  timings.sampling_points = secondsSince(stage);
  std::mt19937 line_rng(samples.rng());
  const auto image_start = Clock::now();
  samples.image = FeatureImage::of(frame.colour, frame.depth);
  const double image_seconds = secondsSince(image_start);  // counted with the point forest
  PredictionParams prediction;
  prediction.max_leaves = params.max_leaves;
  const auto forest_start = Clock::now();
  tbb::task_group branches;
  branches.run([&] {
    auto line_stage = Clock::now();
    if (use_lines && params.line_samples > 0)
      samples.lines = sampleLines(frame, model.params.line_sampling, params.line_samples, line_rng);
    timings.sampling_lines = secondsSince(line_stage);
    line_stage = Clock::now();
    if (use_lines) {
      computeDescriptors(samples.image, samples.lines.samples,
                         model.params.descriptor_normalisation, samples.line_descriptors);
      if (predictions)
        predictForest(model.lines, samples.image, samples.lines.samples, samples.line_descriptors,
                      prediction, predictions->lines);
    }
    timings.forest_lines = secondsSince(line_stage);
  });
  branches.run_and_wait([&] {
    const auto point_stage = Clock::now();
    if (use_points) {
      computeDescriptors(samples.image, samples.points, model.params.descriptor_normalisation,
                         samples.point_descriptors);
      if (predictions)
        predictForest(model.points, samples.image, samples.points, samples.point_descriptors,
                      prediction, predictions->points);
    }
    timings.forest_points = image_seconds + secondsSince(point_stage);
    if (points_ready) (*points_ready)(samples);
  });
  branches.wait();
  timings.sampling = timings.sampling_points + timings.sampling_lines;
  timings.forest = timings.forest_points + timings.forest_lines;
  // With the branches overlapping, the stages add up to more than the wall time.
  timings.sampling_and_forests =
      timings.sampling_points + image_seconds + secondsSince(forest_start);
  // Without predictions the "forest" stages held the descriptors only.
  samples.point_seconds = timings.sampling_points + timings.forest_points;
  samples.line_seconds = timings.sampling_lines + timings.forest_lines;
}

// Both forests on shared samples, side by side.
void predictForests(const Model& model, const RelocalizerParams& params,
                    const FrameSamples& samples, ForestPredictions& predictions,
                    StageTimings& timings) {
  PredictionParams prediction;
  prediction.max_leaves = params.max_leaves;
  const auto start = Clock::now();
  tbb::task_group branches;
  branches.run([&] {
    const auto line_start = Clock::now();
    if (usesLines(model, params))
      predictForest(model.lines, samples.image, samples.lines.samples, samples.line_descriptors,
                    prediction, predictions.lines);
    timings.forest_lines = secondsSince(line_start);
  });
  branches.run_and_wait([&] {
    const auto point_start = Clock::now();
    if (usesPoints(model, params))
      predictForest(model.points, samples.image, samples.points, samples.point_descriptors,
                    prediction, predictions.points);
    timings.forest_points = secondsSince(point_start);
  });
  branches.wait();
  timings.sampling_points = samples.point_seconds;
  timings.sampling_lines = samples.line_seconds;
  timings.sampling = timings.sampling_points + timings.sampling_lines;
  timings.forest = timings.forest_points + timings.forest_lines;
  timings.sampling_and_forests = secondsSince(start);
}

}  // namespace

SamplingRecipe Relocalizer::samplingRecipe() const {
  SamplingRecipe recipe;
  recipe.use_points = usesPoints(model_, params_);
  recipe.use_lines = usesLines(model_, params_);
  recipe.point_samples = params_.point_samples;
  recipe.line_samples = params_.line_samples;
  recipe.min_valid_depth = params_.min_valid_depth;
  recipe.seed = params_.seed;
  recipe.line_sampling = model_.params.line_sampling;
  recipe.colour_normalisation = model_.params.colour_normalisation;
  recipe.descriptor_normalisation = model_.params.descriptor_normalisation;
  return recipe;
}

std::string Relocalizer::frameRefusal(const RgbdFrame& frame) const {
  const std::string invalid = frameValidationError(frame);
  if (!invalid.empty()) return "invalid frame: " + invalid;
  const std::string unusable = validationError();
  if (!unusable.empty()) return unusable;
  const int valid_depth = countValidDepth(frame.depth);
  if (valid_depth < params_.min_valid_depth)
    return "too little valid depth: " + std::to_string(valid_depth) + " pixels (need " +
           std::to_string(params_.min_valid_depth) + ")";
  return {};
}

Relocalization Relocalizer::relocalize(const RgbdFrame& frame, const PoseHint* hint) const {
  return askedInTrainingLight(frame, relocalizeAsSeen(frame, hint), hint);
}

Relocalization Relocalizer::askedInTrainingLight(const RgbdFrame& frame, Relocalization first,
                                                 const PoseHint* hint) const {
  if (first.success || !frameRefusal(frame).empty()) return first;
  return askedAgainInTrainingLight(
      frame, std::move(first), model_, params_.light_retry_min_cast,
      [&](const RgbdFrame& rebalanced) { return relocalizeAsSeen(rebalanced, hint); });
}

Relocalization Relocalizer::confirmedByASecondDraw(const RgbdFrame& frame, Relocalization first,
                                                   const PoseHint* hint) const {
  if (!needsSecondDraw(first, params_.confirm_below)) return first;
  // Another seed: other pixels, other descriptors, another RANSAC stream; the
  // same frame and gates.
  RelocalizerParams drawing = params_;
  drawing.seed = params_.seed + 1;
  return confirmedBySecondDraw(std::move(first), drawAndSolve(frame, hint, drawing),
                               params_.confirm_below);
}

Relocalization Relocalizer::relocalizeAsSeen(const RgbdFrame& frame, const PoseHint* hint) const {
  return confirmedByASecondDraw(frame, drawAndSolve(frame, hint, params_), hint);
}

Relocalization Relocalizer::drawAndSolve(const RgbdFrame& frame, const PoseHint* hint,
                                         const RelocalizerParams& drawing) const {
  const auto start = Clock::now();
  Relocalization result;
  if (std::string refusal = frameRefusal(frame); !refusal.empty())
    return failed(std::move(result), std::move(refusal), start);
  FrameSamples samples;
  samples.recipe = samplingRecipe();
  ForestPredictions predictions;
  sampleFrame(model_, drawing, frame, samples, &predictions, result.timings);
  return solve(frame, samples, predictions.points, predictions.lines, std::move(result), start,
               hint);
}

Expected<FrameSamples> Relocalizer::sample(const RgbdFrame& frame) const {
  return sample(frame, {});
}

Expected<FrameSamples> Relocalizer::sample(
    const RgbdFrame& frame, const std::function<void(const FrameSamples&)>& points_ready) const {
  if (std::string refusal = frameRefusal(frame); !refusal.empty()) return makeError(refusal);
  FrameSamples samples;
  samples.recipe = samplingRecipe();
  StageTimings timings;
  sampleFrame(model_, params_, frame, samples, nullptr, timings,
              points_ready ? &points_ready : nullptr);
  return samples;
}

Relocalization Relocalizer::relocalize(const RgbdFrame& frame, const FrameSamples& samples,
                                       const PoseHint* hint) const {
  if (!samples.recipe.sameAs(samplingRecipe())) return relocalize(frame, hint);
  const auto start = Clock::now();
  Relocalization result;
  ForestPredictions predictions;
  predictForests(model_, params_, samples, predictions, result.timings);
  Relocalization first =
      solve(frame, samples, predictions.points, predictions.lines, std::move(result), start, hint);
  return askedInTrainingLight(frame, confirmedByASecondDraw(frame, std::move(first), hint), hint);
}

ScreenResult Relocalizer::screen(const FrameSamples& samples, const ScreenParams& screen,
                                 std::vector<Prediction>* predictions) const {
  if (model_.points.empty() || samples.points.empty()) return {};
  // The point samples are in random order: the first ones are a random subset.
  const size_t count = std::min(samples.points.size(), static_cast<size_t>(screen.samples));
  std::vector<Prediction> own;
  std::vector<Prediction>& predicted = predictions ? *predictions : own;
  if (predicted.size() < count) {
    const size_t from = predicted.size();
    const std::vector<Sample> subset(samples.points.begin() + from, samples.points.begin() + count);
    const std::vector<Descriptor> descriptors(samples.point_descriptors.begin() + from,
                                              samples.point_descriptors.begin() + count);
    PredictionParams prediction;
    prediction.max_leaves = screen.max_leaves;
    std::vector<Prediction> more;
    predictForest(model_.points, samples.image, subset, descriptors, prediction, more);
    predicted.insert(predicted.end(), more.begin(), more.end());
  }
  std::vector<SolverSample> inputs;
  inputs.reserve(count);
  for (size_t i = 0; i < count; ++i)
    inputs.push_back({samples.points[i].camera_point, &predicted[i], nullptr});
  // A stream of its own: the screen must not change what the full solve draws.
  std::mt19937 rng(params_.seed);
  return screenPose(inputs, params_.solver, screen.hypotheses, screen.sampling_attempts, rng);
}

Relocalization Relocalizer::failed(Relocalization result, std::string message,
                                   std::chrono::steady_clock::time_point start) {
  result.success = false;
  result.message = std::move(message);
  result.timings.total = secondsSince(start);
  return result;
}

Relocalization Relocalizer::solve(const RgbdFrame& frame, const FrameSamples& samples,
                                  const std::vector<Prediction>& point_predictions,
                                  const std::vector<Prediction>& line_predictions,
                                  Relocalization result,
                                  std::chrono::steady_clock::time_point start,
                                  const PoseHint* hint) const {
  const bool use_points = usesPoints(model_, params_);
  result.point_samples = static_cast<int>(samples.points.size());
  result.line_samples = static_cast<int>(samples.lines.samples.size());
  std::vector<SolverSample> point_inputs, line_inputs;
  point_inputs.reserve(samples.points.size());
  for (size_t i = 0; i < samples.points.size(); ++i)
    point_inputs.push_back({samples.points[i].camera_point, &point_predictions[i], nullptr});
  line_inputs.reserve(samples.lines.samples.size());
  for (size_t i = 0; i < samples.lines.samples.size(); ++i) {
    const Sample& s = samples.lines.samples[i];
    line_inputs.push_back({s.camera_point, &line_predictions[i], &samples.lines.lines[s.line]});
  }
  // The solver continues the sampling's stream (a copy: the samples may be shared).
  std::mt19937 rng = samples.rng;
  // Without the point forest, line samples seed the hypotheses too.
  const PoseSolution solution =
      use_points ? solvePose(point_inputs, line_inputs, params_.solver, rng, hint)
                 : solvePose(line_inputs, {}, params_.solver, rng, hint);
  result.timings.ransac = solution.ransac_seconds;
  result.timings.refinement = solution.refinement_seconds;
  result.point_inliers = solution.point_inliers;
  result.line_inliers = solution.line_inliers;
  result.score = solution.score;
  if (!solution.success) return failed(std::move(result), solution.message, start);
  result.pose = solution.pose;
  result.covariance = solution.covariance;

  // Surface: refine by depth ICP and check against the scene's geometry.
  if (params_.surface.enabled && !model_.surface.empty()) {
    const auto surface_start = Clock::now();
    const SurfaceFit fit =
        fitToSurface(model_.surface, surfaceFitPoints(frame, params_.surface.points), solution.pose,
                     params_.surface);
    result.timings.surface = secondsSince(surface_start);
    result.surface_agreement = fit.view.agreement();
    result.surface_refined = fit.refined;
    result.pose = fit.pose;
    std::string refusal = surfaceRefusal(fit.view, params_.surface);
    if (!refusal.empty()) return failed(std::move(result), std::move(refusal), start);
  }
  result.point_inlier_world = inWorld(result.pose, solution.point_inlier_cameras);
  result.line_inlier_world = inWorld(result.pose, solution.line_inlier_cameras);
  result.success = true;
  result.timings.total = secondsSince(start);
  return result;
}

bool SamplingRecipe::sameAs(const SamplingRecipe& other) const {
  const LineSamplingParams &a = line_sampling, &b = other.line_sampling;
  return use_points == other.use_points && use_lines == other.use_lines &&
         point_samples == other.point_samples && line_samples == other.line_samples &&
         min_valid_depth == other.min_valid_depth && seed == other.seed &&
         colour_normalisation == other.colour_normalisation &&
         descriptor_normalisation == other.descriptor_normalisation &&
         a.line_detector == b.line_detector && a.min_segment_length_px == b.min_segment_length_px &&
         a.spacing_px == b.spacing_px && a.lsd_scale == b.lsd_scale &&
         a.lsd_min_width_px == b.lsd_min_width_px && a.lsd_validation == b.lsd_validation &&
         a.edge_offset_px == b.edge_offset_px && a.ransac_inlier_m == b.ransac_inlier_m &&
         a.ransac_iterations == b.ransac_iterations && a.min_inliers == b.min_inliers &&
         a.min_inlier_ratio == b.min_inlier_ratio;
}

std::string Relocalizer::limitations() const {
  if (params_.surface.enabled && model_.surface.empty())
    return "the model has no scene surface (written by an older `train`, or trained with "
           "surface.enabled: false), so poses are neither refined by depth ICP nor checked "
           "against the scene; retrain the model to get both";
  return {};
}

Expected<PredictionQuality> Relocalizer::measurePredictions(const RgbdFrame& recorded,
                                                            bool line_forest, float radius) const {
  if (!recorded.ground_truth) return makeError("frame has no ground truth");
  const std::string invalid = frameValidationError(recorded);
  if (!invalid.empty()) return makeError("invalid frame: " + invalid);
  const RgbdFrame frame = asTrainingSaw(recorded, model_);
  const Forest& forest = line_forest ? model_.lines : model_.points;
  if (forest.empty())
    return makeError(std::string("the model has no ") + (line_forest ? "line" : "point") +
                     " forest");
  std::mt19937 rng(params_.seed);
  std::vector<Sample> samples;
  if (line_forest)
    samples = sampleLines(frame, model_.params.line_sampling, params_.line_samples, rng).samples;
  else
    samplePoints(frame, params_.point_samples, rng, samples);
  const FeatureImage image = FeatureImage::of(frame.colour, frame.depth);
  std::vector<Descriptor> descriptors;
  std::vector<Prediction> predictions;
  computeDescriptors(image, samples, model_.params.descriptor_normalisation, descriptors);
  PredictionParams prediction;
  prediction.max_leaves = params_.max_leaves;
  predictForest(forest, image, samples, descriptors, prediction, predictions);
  PredictionQuality quality;
  const Eigen::Isometry3f pose = frame.ground_truth->cast<float>();
  for (size_t i = 0; i < samples.size(); ++i) {
    const Prediction& p = predictions[i];
    if (p.count == 0) continue;
    const Eigen::Vector3f truth = pose * samples[i].camera_point;
    int chosen = 0;
    bool any = false;
    for (int c = 0; c < p.count; ++c) {
      if (p.candidates[c].descriptor_distance < p.candidates[chosen].descriptor_distance)
        chosen = c;
      any = any || (p.candidates[c].mode.mean - truth).norm() < radius;
    }
    const float error = (p.candidates[chosen].mode.mean - truth).norm();
    ++quality.samples;
    quality.chosen_within += error < radius ? 1 : 0;
    quality.any_within += any ? 1 : 0;
    quality.chosen_errors.push_back(error);
  }
  return quality;
}

}  // namespace relocalizer
