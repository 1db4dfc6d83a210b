#include "training_params_json.h"

#include "relocalizer/core/json_fields.h"
#include "relocalizer/forest/model_io.h"

namespace relocalizer {

namespace {

using detail::checkedNumber;
using detail::readField;
using nlohmann::json;

json meanShiftJson(const MeanShiftParams& p) {
  return {{"bandwidth", p.bandwidth},           {"max_seeds", p.max_seeds},
          {"max_iterations", p.max_iterations}, {"max_modes", p.max_modes},
          {"min_mode_share", p.min_mode_share}, {"min_std", p.min_std}};
}

json forestJson(const ForestParams& p) {
  return {{"trees", p.trees},
          {"max_depth", p.max_depth},
          {"min_samples_leaf", p.min_samples_leaf},
          {"images_per_tree", p.images_per_tree},
          {"samples_per_image", p.samples_per_image},
          {"feature_candidates", p.feature_candidates},
          {"threshold_candidates", p.threshold_candidates},
          {"split_sample_cap", p.split_sample_cap},
          {"max_offset", p.max_offset},
          {"depth_feature_share", p.depth_feature_share},
          {"mean_shift", meanShiftJson(p.mean_shift)}};
}

json surfaceJson(const TrainingParams& p) {
  const SurfaceParams& s = p.surface;
  return {{"enabled", p.build_surface},     {"voxel_size", s.voxel_size},
          {"pixel_stride", s.pixel_stride}, {"normal_step", s.normal_step},
          {"max_depth", s.max_depth},       {"min_frames", s.min_frames}};
}

}  // namespace

namespace detail {

json trainingParamsJson(const TrainingParams& p) {
  const auto& l = p.line_sampling;
  return {{"seed", p.seed},
          {"colour_normalisation", colourNormalisationName(p.colour_normalisation)},
          {"light_augmentation",
           {{"max_stops", p.light_augmentation.max_stops},
            {"min_kelvin", p.light_augmentation.min_kelvin},
            {"max_kelvin", p.light_augmentation.max_kelvin}}},
          {"descriptor_normalisation", descriptorNormalisationName(p.descriptor_normalisation)},
          {"surface", surfaceJson(p)},
          {"train_points", p.train_points},
          {"train_lines", p.train_lines},
          {"points", forestJson(p.points)},
          {"lines", forestJson(p.lines)},
          {"line_sampling",
           {{"line_detector", lineDetectorName(l.line_detector)},
            {"min_segment_length_px", l.min_segment_length_px},
            {"spacing_px", l.spacing_px},
            {"lsd_scale", l.lsd_scale},
            {"lsd_min_width_px", l.lsd_min_width_px},
            {"lsd_validation", l.lsd_validation},
            {"edge_offset_px", l.edge_offset_px},
            {"ransac_inlier_m", l.ransac_inlier_m},
            {"ransac_iterations", l.ransac_iterations},
            {"min_inliers", l.min_inliers},
            {"min_inlier_ratio", l.min_inlier_ratio}}}};
}

}  // namespace detail

namespace {

// JSON values come from files (model headers, merged config), so a number is
// converted only when it fits its field: nlohmann's implicit conversion would
// silently truncate an integer and, for a float read into an integer field,
// is undefined behaviour. Throws std::out_of_range naming the key otherwise.
void readMeanShift(const json& j, const std::string& prefix, MeanShiftParams& p) {
  readField(j, prefix, "bandwidth", p.bandwidth);
  readField(j, prefix, "max_seeds", p.max_seeds);
  readField(j, prefix, "max_iterations", p.max_iterations);
  readField(j, prefix, "max_modes", p.max_modes);
  readField(j, prefix, "min_mode_share", p.min_mode_share);
  readField(j, prefix, "min_std", p.min_std);
}

void readForest(const json& j, const std::string& prefix, ForestParams& p) {
  readField(j, prefix, "trees", p.trees);
  readField(j, prefix, "max_depth", p.max_depth);
  readField(j, prefix, "min_samples_leaf", p.min_samples_leaf);
  readField(j, prefix, "images_per_tree", p.images_per_tree);
  readField(j, prefix, "samples_per_image", p.samples_per_image);
  readField(j, prefix, "feature_candidates", p.feature_candidates);
  readField(j, prefix, "threshold_candidates", p.threshold_candidates);
  readField(j, prefix, "split_sample_cap", p.split_sample_cap);
  readField(j, prefix, "max_offset", p.max_offset);
  readField(j, prefix, "depth_feature_share", p.depth_feature_share);
  readMeanShift(j.at("mean_shift"), prefix + "mean_shift.", p.mean_shift);
}

// One of an enum's names at `key`, read by `named`; `absent` when the key is
// not there (a header written before the choice existed). Throws
// std::out_of_range naming the key and the `choices` otherwise.
template <typename Choice>
Choice readChoice(const json& j, const std::string& prefix, const std::string& key, Choice absent,
                  std::optional<Choice> (*named)(const std::string&), const char* choices) {
  if (!j.contains(key)) return absent;
  const json& name = j.at(key);
  const std::optional<Choice> choice =
      name.is_string() ? named(name.get<std::string>()) : std::nullopt;
  if (!choice)
    throw std::out_of_range("'" + prefix + key + "' must be " + choices + ", got " + name.dump());
  return *choice;
}

void readLightAugmentation(const json& j, LightAugmentation& a) {
  const std::string prefix = "light_augmentation.";
  readField(j, prefix, "max_stops", a.max_stops);
  readField(j, prefix, "min_kelvin", a.min_kelvin);
  readField(j, prefix, "max_kelvin", a.max_kelvin);
  const std::string why = a.validationError();
  if (!why.empty()) throw std::out_of_range(why);
}

void readSurface(const json& j, TrainingParams& p) {
  const std::string prefix = "surface.";
  readField(j, prefix, "enabled", p.build_surface);
  readField(j, prefix, "voxel_size", p.surface.voxel_size);
  readField(j, prefix, "pixel_stride", p.surface.pixel_stride);
  readField(j, prefix, "normal_step", p.surface.normal_step);
  readField(j, prefix, "max_depth", p.surface.max_depth);
  readField(j, prefix, "min_frames", p.surface.min_frames);
}

}  // namespace

namespace detail {

void readTrainingParams(const json& j, TrainingParams& p) {
  readField(j, "", "seed", p.seed);
  // Models written before it existed saw the recorded colour: they keep doing so.
  p.colour_normalisation =
      readChoice(j, "", "colour_normalisation", ColourNormalisation::kNone,
                 colourNormalisationNamed, "\"channel_statistics\", \"local_mean\" or \"none\"");
  // Models written before it existed were trained on the recorded light.
  if (j.contains("light_augmentation"))
    readLightAugmentation(j.at("light_augmentation"), p.light_augmentation);
  // Models written before it existed scaled the whole descriptor.
  p.descriptor_normalisation =
      readChoice(j, "", "descriptor_normalisation", DescriptorNormalisation::kWhole,
                 descriptorNormalisationNamed, "\"per_channel\" or \"whole\"");
  // Version-1 model headers predate the surface: they keep the defaults, and the
  // model no surface (the file has none to read).
  if (j.contains("surface")) readSurface(j.at("surface"), p);
  readField(j, "", "train_points", p.train_points);
  readField(j, "", "train_lines", p.train_lines);
  readForest(j.at("points"), "points.", p.points);
  readForest(j.at("lines"), "lines.", p.lines);
  const json& l = j.at("line_sampling");
  auto& s = p.line_sampling;
  const std::string prefix = "line_sampling.";
  // Models written before our own detector existed used OpenCV's LSD: they
  // keep it, whatever today's default.
  s.line_detector = readChoice(l, prefix, "line_detector", LineDetector::kOpenCvLsd,
                               lineDetectorNamed, "\"own\" or \"opencv_lsd\"");
  readField(l, prefix, "min_segment_length_px", s.min_segment_length_px);
  readField(l, prefix, "spacing_px", s.spacing_px);
  readField(l, prefix, "lsd_scale", s.lsd_scale);
  // Models written before the floor existed ran LSD at lsd_scale alone: they
  // keep doing so, whatever today's default.
  s.lsd_min_width_px = 0;
  if (l.contains("lsd_min_width_px")) readField(l, prefix, "lsd_min_width_px", s.lsd_min_width_px);
  s.lsd_validation = true;  // what every model before the key did
  if (l.contains("lsd_validation")) readField(l, prefix, "lsd_validation", s.lsd_validation);
  readField(l, prefix, "edge_offset_px", s.edge_offset_px);
  readField(l, prefix, "ransac_inlier_m", s.ransac_inlier_m);
  readField(l, prefix, "ransac_iterations", s.ransac_iterations);
  readField(l, prefix, "min_inliers", s.min_inliers);
  readField(l, prefix, "min_inlier_ratio", s.min_inlier_ratio);
}

}  // namespace detail

std::string trainingParamsToJson(const TrainingParams& params) {
  return detail::trainingParamsJson(params).dump(2);
}

Expected<TrainingParams> trainingParamsFromJson(const std::string& json_text) {
  TrainingParams params;
  try {
    detail::readTrainingParams(json::parse(json_text), params);
  } catch (const std::exception& e) {
    return makeError(std::string("training parameters: ") + e.what());
  }
  return params;
}

}  // namespace relocalizer
