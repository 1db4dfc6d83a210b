#include "relocalizer/forest/model_builder.h"

#include <chrono>

namespace relocalizer {

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
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
