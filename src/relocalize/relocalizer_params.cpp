// RelocalizerParams as JSON (model headers, summaries, the node's
// `relocalizer:` section) and from YAML files: relocalizer.h's
// relocalizerParamsToJson, relocalizerParamsFromJson, loadRelocalizerParams.

#include "relocalizer/relocalize/relocalizer.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "relocalizer/core/config.h"
#include "relocalizer/core/json_fields.h"

namespace relocalizer {

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
          {"light_retry_min_cast", p.light_retry_min_cast},
          {"confirm_below", p.confirm_below},
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
            {"min_inlier_ratio", s.min_inlier_ratio},
            {"hint_weight", s.hint_weight}}},
          {"surface",
           {{"enabled", p.surface.enabled},
            {"points", p.surface.points},
            {"iterations", p.surface.iterations},
            {"max_distance", p.surface.max_distance},
            {"huber", p.surface.huber},
            {"tolerance", p.surface.tolerance},
            {"min_agreement", p.surface.min_agreement},
            {"min_on_surface", p.surface.min_on_surface},
            {"max_seen_through", p.surface.max_seen_through},
            {"occlusion_margin", p.surface.occlusion_margin},
            {"occlusion_reach", p.surface.occlusion_reach},
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
    // Written since the light retry and the second draw (issue 40); older parameter files keep
    // the defaults.
    if (j.contains("light_retry_min_cast"))
      readField(j, "", "light_retry_min_cast", p.light_retry_min_cast);
    if (j.contains("confirm_below")) readField(j, "", "confirm_below", p.confirm_below);
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
    // Written since pose hints (issue 27); older parameter files keep the default.
    if (s.contains("hint_weight")) readField(s, at, "hint_weight", q.hint_weight);
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
    // Written since the occlusion-aware surface check; older parameter files keep the defaults.
    for (const auto& [key, value] :
         {std::pair<const char*, float*>{"min_on_surface", &r.min_on_surface},
          {"max_seen_through", &r.max_seen_through},
          {"occlusion_margin", &r.occlusion_margin},
          {"occlusion_reach", &r.occlusion_reach}})
      if (f.contains(key)) readField(f, in, key, *value);
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
