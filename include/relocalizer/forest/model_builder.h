#pragma once
// Posed frames in, a model out: the one place a model is assembled from
// images (`train`, the online learner and the tests all build through it), so
// the forests, the surface and the training summary are made the same way
// everywhere.
//
// The surface is fused before the forests grow: forest training releases each
// image's depth once every tree has drawn its samples from it, and the surface
// is fused from that depth. The order changes no byte of the model: the
// forests never read the surface, fusion draws no random numbers, and the
// samples keep their own depth.

#include <functional>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training.h"

namespace relocalizer {

struct ModelBuildProgress {
  TrainingProgress forests;
  // Called once the surface is fused, with its wall time (not when the
  // parameters build none).
  std::function<void(double seconds)> surface_built;
};

class ModelBuilder {
 public:
  explicit ModelBuilder(TrainingParams params) : params_(std::move(params)) {}

  // A frame posed by its ground truth (camera-to-world); false, and nothing
  // kept, when it has none.
  bool add(const RgbdFrame& frame);
  // An image with the colour as recorded (a learner's key frame): the forests
  // see it through the parameters' colour normalisation, as the relocalizer
  // sees the frames it is asked about.
  void add(TrainingImage image);
  size_t size() const { return images_.size(); }

  // Grows the forests and fuses the surface that `params` enable and fills the
  // summary: `provenance` gives dataset, format, frames and threads; the
  // images' count and bounds, the software version and the wall time of the
  // build are added here. Consumes the images (they are the bulk of training's
  // memory). Fails without images. Exceptions thrown by the progress callbacks
  // (a learner's abort) pass through.
  Expected<Model> build(TrainingSummary provenance, const ModelBuildProgress& progress = {});

 private:
  TrainingParams params_;
  std::vector<TrainingImage> images_;
};

}  // namespace relocalizer
