#include "relocalizer/forest/model_builder.h"

#include <chrono>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/core/version.h"

namespace relocalizer {

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The part of a summary that follows from the training images: their count,
// the bounds of their camera centres, the light's chromaticity and where each
// image's light fell, and this build's software version.
void summarizeTrainingImages(const std::vector<TrainingImage>& images, TrainingSummary& summary) {
  summary.images = static_cast<int>(images.size());
  summary.software_version = kSoftwareVersion;
  summary.view_lights.clear();
  if (images.empty()) return;
  summary.scene_min = summary.scene_max = images.front().pose.translation().cast<float>();
  for (const auto& image : images) {
    summary.scene_min = summary.scene_min.cwiseMin(image.pose.translation().cast<float>());
    summary.scene_max = summary.scene_max.cwiseMax(image.pose.translation().cast<float>());
  }
  cv::Vec3d chromaticity(0.0, 0.0, 0.0);
  int coloured = 0;
  for (const auto& image : images)
    if (image.colour.type() == CV_8UC3 && !image.colour.empty()) {
      chromaticity += lightChromaticity(image.colour);
      summary.view_lights.push_back(lightGrid(image.colour));
      ++coloured;
    }
  if (coloured > 0) chromaticity /= static_cast<double>(coloured);
  summary.light_chromaticity =
      Eigen::Vector3d(chromaticity[0], chromaticity[1], chromaticity[2]).cast<float>();
}

}  // namespace

bool ModelBuilder::add(const RgbdFrame& frame) {
  return appendTrainingImage(frame, params_, images_);
}

void ModelBuilder::add(TrainingImage image) {
  appendTrainingImage(std::move(image), params_, images_);
}

Expected<Model> ModelBuilder::build(TrainingSummary provenance,
                                    const ModelBuildProgress& progress) {
  if (images_.empty()) return makeError("no posed frame to train on");
  if (params_.train_lines) {
    const std::string missing = lineDetectorMissing(params_.line_sampling.line_detector);
    if (!missing.empty()) return makeError(missing + "; use line_detector: own");
  }
  const auto start = std::chrono::steady_clock::now();
  Model model;
  model.params = params_;
  model.summary = std::move(provenance);
  summarizeTrainingImages(images_, model.summary);
  if (params_.build_surface) {
    const auto surface_start = std::chrono::steady_clock::now();
    model.surface = buildSurface(images_, params_.surface);
    if (progress.surface_built) progress.surface_built(secondsSince(surface_start));
  }
  std::vector<TrainingImage> images = std::move(images_);
  images_.clear();
  trainForestsReleasingDepth(images, params_, model.points, model.lines, progress.forests);
  model.summary.seconds = secondsSince(start);
  return model;
}

}  // namespace relocalizer
