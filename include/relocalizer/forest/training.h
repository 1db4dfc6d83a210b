#pragma once
// Growing the point and line forests from posed RGB-D frames.
//
// Per tree: a random subset of the training images, a sample of pixels from
// each (random pixels with depth for the point forest, line samples for the
// line forest), labelled with their world coordinates. Nodes split greedily on
// random depth-adaptive pixel comparisons, keeping the candidate that maximises
// information gain under a full-covariance Gaussian model of the labels. Leaves
// hold the mean-shift modes of their labels with each mode's mean descriptor.
//
// Trees are independent and each has its own random stream derived from the
// seed, so the result is the same for any thread count.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/forest/colour_normalisation.h"
#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/light_augmentation.h"
#include "relocalizer/forest/mean_shift.h"
#include "relocalizer/forest/patch_descriptor.h"
#include "relocalizer/forest/sampling.h"
#include "relocalizer/surface/surface_model.h"

namespace relocalizer {

enum class ForestKind { Points = 0, Lines = 1 };
const char* forestKindName(ForestKind kind);

struct ForestParams {
  int trees = 5;
  int max_depth = 25;
  int min_samples_leaf = 20;         // no split leaves a child with fewer samples
  int images_per_tree = 500;         // capped by the number of training images
  int samples_per_image = 5000;      // pixels (or line samples) drawn per image
  int feature_candidates = 16;       // random features per node (32, 64 before: benchmarks.md)
  int threshold_candidates = 16;     // random thresholds tried per feature
  int split_sample_cap = 1000;       // samples used to score splits at a node
  float max_offset = 130.0f;         // |delta| per axis, pixel-metres
  float depth_feature_share = 0.0f;  // share of depth-difference candidates
  MeanShiftParams mean_shift;
};

struct TrainingParams {
  uint64_t seed = 42;
  ForestParams points;
  ForestParams lines;
  LineSamplingParams line_sampling;
  // What the forests see of the colour (colour_normalisation.h); models
  // written before it existed read kNone. Not yet a default: the whole
  // frame's statistics lose frames with people in view, and the local mean
  // lets a place learned from sparse key frames take a look-alike view for
  // one it knows (docs/benchmarks.md).
  ColourNormalisation colour_normalisation = ColourNormalisation::kNone;
  // The lights each training image is seen under before the normalisation
  // (light_augmentation.h); models written before it existed read none.
  LightAugmentation light_augmentation;
  // How the patch descriptors are scaled (patch_descriptor.h); models written
  // before it existed read kWhole.
  DescriptorNormalisation descriptor_normalisation = DescriptorNormalisation::kWhole;
  bool train_points = true;
  bool train_lines = true;
  bool build_surface = true;  // fuse the images' depth into the scene surface (surface_model.h)
  SurfaceParams surface;
};

// Differential-entropy bookkeeping for a set of 3D labels: sufficient
// statistics, so child statistics come from sums over threshold bins.
struct LabelStats {
  double count = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  // Upper triangle of sum x x^T: xx xy xz yy yz zz.
  std::array<double, 6> square{};

  void add(const Eigen::Vector3f& x);
  // Inline: the split search's innermost loop (out of line, the call was 6 %
  // of a tree's training time).
  void add(const LabelStats& other) {
    count += other.count;
    sum += other.sum;
    for (int i = 0; i < 6; ++i) square[i] += other.square[i];
  }
  Eigen::Matrix3d covariance() const;
  // 0.5 log((2 pi e)^3 det Sigma) with a tiny diagonal regulariser so that
  // degenerate sets (all labels equal) stay finite.
  double entropy() const;
};

// Closed-form differential entropy of a 3D Gaussian with covariance `sigma`.
double gaussianEntropy(const Eigen::Matrix3d& sigma);

// One posed training frame, kept in memory for feature evaluation.
struct TrainingImage {
  cv::Mat colour;  // CV_8UC3
  cv::Mat depth;   // CV_32FC1 metres (released after sampling by trainForestsReleasingDepth)
  CameraIntrinsics camera;
  Pose pose;  // camera-to-world
  FeatureImage view() const { return FeatureImage::of(colour, depth); }
};

struct TrainingProgress {
  // Called once per forest with the number of samples its trees will grow on.
  std::function<void(size_t)> samples_drawn;
  // Called from worker threads with the number of samples that reached a leaf.
  std::function<void(size_t)> samples_done;
  // Called when a tree is complete, with its forest, index and wall time.
  std::function<void(ForestKind, int, double)> tree_done;
};

// Samples each tree of `kind` trains on (exposed for tests and the progress total).
struct TreeSamples {
  struct Item {
    int32_t image;
    int16_t u, v;
    float depth;
    Eigen::Vector3f world;
    // The colour at (u, v), BGR. Every colour feature reads it; kept here, one
    // sequential read replaces a cache miss in an image per evaluation.
    std::array<uint8_t, 3> colour;
  };
  std::vector<Item> items;
};

// Draws the training samples of every tree of one forest. Line samples of each
// image are detected once and subsampled per tree. The same samples as each
// tree drawing alone from its chosen images in order.
std::vector<TreeSamples> drawTreeSamples(const std::vector<TrainingImage>& images, ForestKind kind,
                                         const TrainingParams& params);

// Grows one tree from its samples (consumed: reordered in place).
Tree growTree(const std::vector<TrainingImage>& images, TreeSamples& samples,
              const ForestParams& params, DescriptorNormalisation descriptors, uint64_t seed,
              const TrainingProgress& progress = {});

// Grows all trees of one forest, in parallel over trees (TBB, bounded by the
// caller's tbb::global_control), largest first.
Forest trainForest(const std::vector<TrainingImage>& images, ForestKind kind,
                   const TrainingParams& params, const TrainingProgress& progress = {});

// Derived per-tree seed: independent streams for every (seed, forest, tree).
uint64_t treeSeed(uint64_t seed, ForestKind kind, int tree);

}  // namespace relocalizer

namespace relocalizer {

// A posed frame as training keeps it, its colour as the forests see it: under
// the light `params` draw for the image's place in `images`, then normalised.
// False (and nothing appended) when the frame has no ground truth.
bool appendTrainingImage(const RgbdFrame& frame, const TrainingParams& params,
                         std::vector<TrainingImage>& images);
// The same for an image that already has its pose (colour as recorded).
void appendTrainingImage(TrainingImage image, const TrainingParams& params,
                         std::vector<TrainingImage>& images);

// The scene surface fused from the images' depth at their poses, in image order
// (so the same images give the same surface).
SurfaceModel buildSurface(const std::vector<TrainingImage>& images, const SurfaceParams& params);

// Grows the point and line forests (those enabled in `params`): every tree's
// samples first, then all trees of both forests in parallel, largest first.
// Unless a forest uses depth features, each image's depth is released as soon
// as every tree has drawn its samples from it (samples keep their own depth),
// so training holds colour only, 0.9 instead of 2.1 MB per VGA frame; the
// model builder (model_builder.h) fuses the surface first.
void trainForestsReleasingDepth(std::vector<TrainingImage>& images, const TrainingParams& params,
                                Forest& points, Forest& lines,
                                const TrainingProgress& progress = {});

}  // namespace relocalizer
