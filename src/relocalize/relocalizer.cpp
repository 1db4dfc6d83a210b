#include "relocalizer/relocalize/relocalizer.h"

#include <yaml-cpp/yaml.h>

#include <tbb/task_group.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "relocalizer/core/config.h"
#include "relocalizer/core/json_fields.h"

namespace relocalizer {

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
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
  if (params_.solver.hypotheses < 1 || params_.solver.batch_size < 1)
    return "solver.hypotheses and solver.batch_size must be >= 1";
  const SurfaceFitParams& s = params_.surface;
  if (s.points < 1 || s.iterations < 0 || s.min_correspondences < 0)
    return "surface.points must be >= 1, surface.iterations and surface.min_correspondences >= 0";
  if (!(s.max_distance > 0 && s.huber > 0 && s.tolerance > 0))
    return "surface.max_distance, surface.huber and surface.tolerance must be positive (metres)";
  if (!(s.min_agreement >= 0 && s.min_agreement <= 1))
    return "surface.min_agreement must be a share between 0 and 1";
  return {};
}

Relocalization Relocalizer::relocalize(const RgbdFrame& frame) const {
  const auto start = Clock::now();
  Relocalization result;
  auto fail = [&](std::string message) {
    result.success = false;
    result.message = std::move(message);
    result.timings.total = secondsSince(start);
    return result;
  };
  const std::string invalid = frameValidationError(frame);
  if (!invalid.empty()) return fail("invalid frame: " + invalid);
  const std::string unusable = validationError();
  if (!unusable.empty()) return fail(unusable);
  const int valid_depth = countValidDepth(frame.depth);
  if (valid_depth < params_.min_valid_depth)
    return fail("too little valid depth: " + std::to_string(valid_depth) + " pixels (need " +
                std::to_string(params_.min_valid_depth) + ")");

  std::mt19937 rng(params_.seed);
  const bool use_points = params_.use_points && !model_.points.empty();
  const bool use_lines = params_.use_lines && !model_.lines.empty();

  // --- Sampling and forests ----------------------------------------------------------
  // Two branches that share nothing but the frame: random pixels -> point
  // forest, and LSD -> line samples -> line forest. LSD runs on one core
  // whatever the thread count, so with two or more threads it overlaps the
  // point forest instead of leaving a core idle; with one thread the branches
  // run one after the other. The point samples are drawn first and the line
  // branch has its own random stream forked from the seed, so the answer does
  // not depend on which branch runs first.
  auto stage = Clock::now();
  std::vector<Sample> point_samples;
  LineSamples line_samples;
  if (use_points) samplePoints(frame, params_.point_samples, rng, point_samples);
  result.timings.sampling_points = secondsSince(stage);
  std::mt19937 line_rng(rng());
  const auto image_start = Clock::now();
  const FeatureImage image = FeatureImage::of(frame.colour, frame.depth);
  const double image_seconds = secondsSince(image_start);  // counted with the point forest
  PredictionParams prediction;
  prediction.max_leaves = params_.max_leaves;
  std::vector<Descriptor> point_descriptors, line_descriptors;
  std::vector<Prediction> point_predictions, line_predictions;
  const auto forest_start = Clock::now();
  tbb::task_group branches;
  branches.run([&] {
    auto line_stage = Clock::now();
    if (use_lines && params_.line_samples > 0)
      line_samples =
          sampleLines(frame, model_.params.line_sampling, params_.line_samples, line_rng);
    result.timings.sampling_lines = secondsSince(line_stage);
    line_stage = Clock::now();
    if (use_lines) {
      computeDescriptors(image, line_samples.samples, line_descriptors);
      predictForest(model_.lines, image, line_samples.samples, line_descriptors, prediction,
                    line_predictions);
    }
    result.timings.forest_lines = secondsSince(line_stage);
  });
  branches.run_and_wait([&] {
    const auto point_stage = Clock::now();
    if (use_points) {
      computeDescriptors(image, point_samples, point_descriptors);
      predictForest(model_.points, image, point_samples, point_descriptors, prediction,
                    point_predictions);
    }
    result.timings.forest_points = image_seconds + secondsSince(point_stage);
  });
  branches.wait();
  result.point_samples = static_cast<int>(point_samples.size());
  result.line_samples = static_cast<int>(line_samples.samples.size());
  result.timings.sampling = result.timings.sampling_points + result.timings.sampling_lines;
  result.timings.forest = result.timings.forest_points + result.timings.forest_lines;
  // With the branches overlapping, the stages add up to more than the wall time.
  result.timings.sampling_and_forests =
      result.timings.sampling_points + image_seconds + secondsSince(forest_start);

  // --- Pose --------------------------------------------------------------------------
  std::vector<SolverSample> point_inputs, line_inputs;
  point_inputs.reserve(point_samples.size());
  for (size_t i = 0; i < point_samples.size(); ++i)
    point_inputs.push_back({point_samples[i].camera_point, &point_predictions[i], nullptr});
  line_inputs.reserve(line_samples.samples.size());
  for (size_t i = 0; i < line_samples.samples.size(); ++i) {
    const Sample& s = line_samples.samples[i];
    line_inputs.push_back({s.camera_point, &line_predictions[i], &line_samples.lines[s.line]});
  }
  // Without the point forest, line samples seed the hypotheses too.
  const PoseSolution solution = use_points
                                    ? solvePose(point_inputs, line_inputs, params_.solver, rng)
                                    : solvePose(line_inputs, {}, params_.solver, rng);
  result.timings.ransac = solution.ransac_seconds;
  result.timings.refinement = solution.refinement_seconds;
  result.point_inliers = solution.point_inliers;
  result.line_inliers = solution.line_inliers;
  result.score = solution.score;
  if (!solution.success) return fail(solution.message);
  result.pose = solution.pose;
  result.covariance = solution.covariance;

  // --- Surface: refine by depth ICP and check against the scene's geometry ---------------
  if (params_.surface.enabled && !model_.surface.empty()) {
    const auto surface_start = Clock::now();
    const SurfaceFit fit =
        fitToSurface(model_.surface, surfaceFitPoints(frame, params_.surface.points), solution.pose,
                     params_.surface);
    result.timings.surface = secondsSince(surface_start);
    result.surface_agreement = fit.agreement;
    result.surface_refined = fit.refined;
    result.pose = fit.pose;
    if (fit.agreement < params_.surface.min_agreement) {
      char buffer[200];
      std::snprintf(
          buffer, sizeof buffer,
          "the pose does not fit the scene's surface: %.1f%% of the frame's depth lies on "
          "it (need %.1f%%)",
          100.0 * fit.agreement, 100.0 * params_.surface.min_agreement);
      return fail(buffer);
    }
  }
  result.success = true;
  result.timings.total = secondsSince(start);
  return result;
}

std::string Relocalizer::limitations() const {
  if (params_.surface.enabled && model_.surface.empty())
    return "the model has no scene surface (written by an older `train`, or trained with "
           "surface.enabled: false), so poses are neither refined by depth ICP nor checked "
           "against the scene; retrain the model to get both";
  return {};
}

Expected<PredictionQuality> Relocalizer::measurePredictions(const RgbdFrame& frame,
                                                            bool line_forest, float radius) const {
  if (!frame.ground_truth) return makeError("frame has no ground truth");
  const std::string invalid = frameValidationError(frame);
  if (!invalid.empty()) return makeError("invalid frame: " + invalid);
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
  computeDescriptors(image, samples, descriptors);
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
      any = any || (p.candidates[c].mode->mean - truth).norm() < radius;
    }
    const float error = (p.candidates[chosen].mode->mean - truth).norm();
    ++quality.samples;
    quality.chosen_within += error < radius ? 1 : 0;
    quality.any_within += any ? 1 : 0;
    quality.chosen_errors.push_back(error);
  }
  return quality;
}

// --- Parameters <-> JSON ---------------------------------------------------------------

namespace {
using nlohmann::json;

json toJson(const RelocalizerParams& p) {
  const PoseSolverParams& s = p.solver;
  return {{"point_samples", p.point_samples},
          {"line_samples", p.line_samples},
          {"max_leaves", p.max_leaves},
          {"use_points", p.use_points},
          {"use_lines", p.use_lines},
          {"min_valid_depth", p.min_valid_depth},
          {"seed", p.seed},
          {"solver",
           {{"hypotheses", s.hypotheses},
            {"batch_size", s.batch_size},
            {"max_sampling_attempts", s.max_sampling_attempts},
            {"min_point_distance", s.min_point_distance},
            {"rigidity_tolerance", s.rigidity_tolerance},
            {"rigidity_ratio", s.rigidity_ratio},
            {"inlier_chi2", s.inlier_chi2},
            {"lm_hypotheses", s.lm_hypotheses},
            {"lm_loop_iterations", s.lm_loop_iterations},
            {"lm_iterations", s.lm_iterations},
            {"max_refinement_terms", s.max_refinement_terms},
            {"robust_scale", s.robust_scale},
            {"use_lines_in_refinement", s.use_lines_in_refinement},
            {"min_inliers", s.min_inliers},
            {"min_inlier_ratio", s.min_inlier_ratio}}},
          {"surface",
           {{"enabled", p.surface.enabled},
            {"points", p.surface.points},
            {"iterations", p.surface.iterations},
            {"max_distance", p.surface.max_distance},
            {"huber", p.surface.huber},
            {"tolerance", p.surface.tolerance},
            {"min_agreement", p.surface.min_agreement},
            {"min_correspondences", p.surface.min_correspondences}}}};
}
}  // namespace

std::string relocalizerParamsToJson(const RelocalizerParams& params) {
  return toJson(params).dump(2);
}

Expected<RelocalizerParams> relocalizerParamsFromJson(const std::string& json_text) {
  using detail::readField;
  RelocalizerParams p;
  try {
    const json j = json::parse(json_text);
    readField(j, "", "point_samples", p.point_samples);
    readField(j, "", "line_samples", p.line_samples);
    readField(j, "", "max_leaves", p.max_leaves);
    readField(j, "", "use_points", p.use_points);
    readField(j, "", "use_lines", p.use_lines);
    readField(j, "", "min_valid_depth", p.min_valid_depth);
    readField(j, "", "seed", p.seed);
    const json& s = j.at("solver");
    const std::string at = "solver.";
    PoseSolverParams& q = p.solver;
    readField(s, at, "hypotheses", q.hypotheses);
    readField(s, at, "batch_size", q.batch_size);
    readField(s, at, "max_sampling_attempts", q.max_sampling_attempts);
    readField(s, at, "min_point_distance", q.min_point_distance);
    readField(s, at, "rigidity_tolerance", q.rigidity_tolerance);
    readField(s, at, "rigidity_ratio", q.rigidity_ratio);
    readField(s, at, "inlier_chi2", q.inlier_chi2);
    readField(s, at, "lm_hypotheses", q.lm_hypotheses);
    readField(s, at, "lm_loop_iterations", q.lm_loop_iterations);
    readField(s, at, "lm_iterations", q.lm_iterations);
    readField(s, at, "max_refinement_terms", q.max_refinement_terms);
    readField(s, at, "robust_scale", q.robust_scale);
    readField(s, at, "use_lines_in_refinement", q.use_lines_in_refinement);
    readField(s, at, "min_inliers", q.min_inliers);
    readField(s, at, "min_inlier_ratio", q.min_inlier_ratio);
    const json& f = j.at("surface");
    const std::string in = "surface.";
    SurfaceFitParams& r = p.surface;
    readField(f, in, "enabled", r.enabled);
    readField(f, in, "points", r.points);
    readField(f, in, "iterations", r.iterations);
    readField(f, in, "max_distance", r.max_distance);
    readField(f, in, "huber", r.huber);
    readField(f, in, "tolerance", r.tolerance);
    readField(f, in, "min_agreement", r.min_agreement);
    readField(f, in, "min_correspondences", r.min_correspondences);
  } catch (const std::exception& e) {
    return makeError(std::string("relocalizer parameters: ") + e.what());
  }
  return p;
}

Expected<RelocalizerParams> loadRelocalizerParams(const std::string& path,
                                                  const RelocalizerParams& defaults) {
  std::ifstream in(path);
  if (!in) return makeError(path + ": cannot open configuration file");
  std::stringstream text;
  text << in.rdbuf();
  YAML::Node section;
  try {
    const YAML::Node root = YAML::Load(text.str());
    if (root.IsMap() && root["relocalizer"]) section = root["relocalizer"];
  } catch (const YAML::Exception& e) {
    return makeError(path + ": not valid YAML: " + e.what());
  }
  if (!section) return defaults;
  YAML::Emitter emitter;
  emitter << section;
  auto merged = mergeYamlOntoJson(emitter.c_str(), relocalizerParamsToJson(defaults),
                                  path + " (relocalizer)");
  if (!merged) return makeError(merged.error());
  return relocalizerParamsFromJson(*merged);
}

}  // namespace relocalizer
