// The model loader: relocalizer::deserializeModel on the input bytes, once as
// given and once with the CRC-32 field recomputed over the body, so mutations
// reach the header JSON and forest checks behind the checksum. A model that
// loads is then used the way the relocalizer uses it (header JSON, forest
// statistics, prediction on a tiny frame), because the loader's structural
// checks exist to make exactly that safe.

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <vector>

#include "relocalizer/forest/forest.h"
#include "relocalizer/forest/model_io.h"

using namespace relocalizer;

namespace {

constexpr size_t kBodySizeOffset = 16;
constexpr size_t kCrcOffset = 24;
constexpr size_t kBodyOffset = 28;

// A frame allocated to its exact size, so a read past it is an ASan report.
struct TinyImage {
  static constexpr int kWidth = 5, kHeight = 4;
  std::vector<uint8_t> colour = std::vector<uint8_t>(kWidth * kHeight * 3);
  std::vector<float> depth = std::vector<float>(kWidth * kHeight);
  FeatureImage view;
  TinyImage() {
    for (size_t i = 0; i < colour.size(); ++i) colour[i] = static_cast<uint8_t>(i * 37);
    for (size_t i = 0; i < depth.size(); ++i) depth[i] = i % 5 == 0 ? NAN : 0.5f + 0.1f * i;
    view.colour = colour.data();
    view.depth = depth.data();
    view.width = kWidth;
    view.height = kHeight;
    view.colour_stride = kWidth * 3;
    view.depth_stride = kWidth;
  }
};

// What prediction relies on, checked independently of the loader: a model
// that loads must satisfy all of it, whatever the bytes were.
void checkInvariants(const Forest& forest) {
  if (forest.trees.size() > static_cast<size_t>(kMaxTrees)) std::abort();
  for (const Tree& tree : forest.trees) {
    if (tree.nodes.empty() || tree.descriptors.size() != tree.modes.size()) std::abort();
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const SplitNode& node = tree.nodes[i];
      if (node.left < 0) {
        const LeafRange leaf = node.leafModes();
        if (static_cast<uint64_t>(leaf.first_mode) + leaf.mode_count > tree.modes.size())
          std::abort();
        continue;
      }
      if (static_cast<size_t>(node.left) <= i ||
          static_cast<size_t>(node.left) + 1 >= tree.nodes.size())
        std::abort();
      const PixelFeature& f = node.feature;
      if (f.type == FeatureType::Colour && (f.channel_p > 2 || f.channel_q > 2)) std::abort();
    }
  }
}

void useForest(const Forest& forest) {
  checkInvariants(forest);
  static const TinyImage image;
  (void)forest.nodeCount();
  (void)forest.leafCount();
  (void)forest.modeCount();
  Sample corners[2];
  corners[0].u = 0;
  corners[0].v = 0;
  corners[0].depth = 0.25f;
  corners[1].u = TinyImage::kWidth - 1;
  corners[1].v = TinyImage::kHeight - 1;
  corners[1].depth = 2.0f;
  Descriptor descriptor{};
  descriptor[0] = 127;
  const size_t trees = std::min<size_t>(forest.trees.size(), kMaxTrees);
  for (size_t t = 0; t < trees; ++t) {
    const Tree& tree = forest.trees[t];
    (void)tree.depth();
    for (const Sample& s : corners) {
      (void)tree.descend(image.view, s.u, s.v, s.depth);
      const ModeCandidate c = predictInTree(tree, image.view, s, descriptor, 8);
      if (c.found()) {
        (void)c.mode.mahalanobisSquared(Eigen::Vector3f(1.0f, 2.0f, 3.0f));
        (void)c.mode.covariance();
      }
    }
  }
  // The lock-step descent reads the same arrays by another path.
  const std::vector<Sample> samples(std::begin(corners), std::end(corners));
  const std::vector<Descriptor> descriptors(samples.size(), descriptor);
  std::vector<Prediction> predictions;
  predictForest(forest, image.view, samples, descriptors, PredictionParams{}, predictions);
}

void exercise(const uint8_t* data, size_t size) {
  auto model = deserializeModel(data, size, "fuzz.model");
  if (!model) return;
  (void)modelHeaderJson(*model);
  useForest(model->points);
  useForest(model->lines);
  // Saving what was loaded must work and give a file that loads again.
  const std::vector<uint8_t> bytes = serializeModel(*model);
  (void)deserializeModel(bytes.data(), bytes.size(), "resaved.model");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  exercise(data, size);
  if (size >= kBodyOffset) {
    std::vector<uint8_t> fixed(data, data + size);
    uint64_t body_size = 0;
    std::memcpy(&body_size, fixed.data() + kBodySizeOffset, sizeof body_size);
    const size_t body = std::min<uint64_t>(body_size, size - kBodyOffset);
    const uint32_t crc =
        static_cast<uint32_t>(crc32(0L, fixed.data() + kBodyOffset, static_cast<uInt>(body)));
    std::memcpy(fixed.data() + kCrcOffset, &crc, sizeof crc);
    exercise(fixed.data(), fixed.size());
  }
  return 0;
}
