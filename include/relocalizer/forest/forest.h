#pragma once
// Regression forests mapping a pixel to world coordinates, stored as flat
// arrays (nodes, modes, descriptors) so prediction touches contiguous memory
// and a model loads with a handful of reads. Prediction backtracks through up
// to `max_leaves` leaves per tree, visiting the untaken branches in order of
// |f - tau| (how narrowly the sample missed them), and keeps, per tree, the
// mode whose descriptor is nearest to the sample's.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "relocalizer/forest/features.h"
#include "relocalizer/forest/leaf_mode.h"
#include "relocalizer/forest/packed_mode.h"
#include "relocalizer/forest/patch_descriptor.h"
#include "relocalizer/forest/sampling.h"

namespace relocalizer {

struct LeafRange {
  uint32_t first_mode = 0;
  uint32_t mode_count = 0;
};

// A split (feature, threshold, children) or a leaf. A leaf keeps its mode
// range in the bytes a split uses for its feature, so reaching a leaf needs no
// lookup in another array: prediction waits on one memory access fewer.
struct SplitNode {
  PixelFeature feature;    // splits only; leaves: their LeafRange (leafModes())
  float threshold = 0.0f;  // f < threshold goes left
  int32_t left = -1;  // >= 0: index of the left child (the right child follows it); < 0: a leaf

  bool isLeaf() const { return left < 0; }
  LeafRange leafModes() const {
    LeafRange range;
    std::memcpy(static_cast<void*>(&range), &feature, sizeof range);
    return range;
  }
  static SplitNode leaf(const LeafRange& range) {
    SplitNode node;
    std::memcpy(static_cast<void*>(&node.feature), &range, sizeof range);
    return node;
  }
};
static_assert(sizeof(SplitNode) == 16, "SplitNode layout is part of the model format");
static_assert(sizeof(LeafRange) == sizeof(PixelFeature), "a leaf's range replaces the feature");

struct Tree {
  std::vector<SplitNode> nodes;  // nodes[0] is the root; children follow their parent
  // Leaves' modes, leaf by leaf, packed on the grid (packed_mode.h); the
  // descriptors, read only to choose among modes, are a parallel array.
  ModeGrid grid;
  std::vector<PackedMode> modes;
  std::vector<Descriptor> descriptors;  // descriptors[m]: the mean WHT descriptor of modes[m]

  LeafMode mode(uint32_t m) const { return unpackMode(modes[m], grid); }

  int depth() const;
  size_t leafCount() const;
  // Modes of the leaf reached by plain descent (no backtracking).
  LeafRange descend(const FeatureImage& image, int u, int v, float depth) const;
};

struct Forest {
  std::vector<Tree> trees;
  bool empty() const { return trees.empty(); }
  size_t nodeCount() const;
  size_t leafCount() const;
  size_t modeCount() const;
};

constexpr int kMaxTrees = 16;

// A tree's choice for one sample: its mode unpacked, so that RANSAC and
// refinement read it from the prediction and not from the model.
struct ModeCandidate {
  LeafMode mode;
  int32_t descriptor_distance = kNoDescriptorDistance;
  static constexpr int32_t kNoDescriptorDistance = std::numeric_limits<int32_t>::max();
  bool found() const { return descriptor_distance != kNoDescriptorDistance; }
};

// Candidate world modes for one sample, one per tree that had any mode.
struct Prediction {
  std::array<ModeCandidate, kMaxTrees> candidates;
  int count = 0;
};

struct PredictionParams {
  int max_leaves = 8;  // leaves visited per tree, including the first
};

// Best mode (nearest descriptor) among the leaves visited in one tree, or an
// empty candidate if the tree's leaves hold no mode. Allocation-free.
ModeCandidate predictInTree(const Tree& tree, const FeatureImage& image, const Sample& sample,
                            const Descriptor& descriptor, int max_leaves);

// Predictions for every sample, in parallel over blocks of samples, each
// block descending a tree in lock-step (the candidates are predictInTree's).
// `descriptors[i]` belongs to `samples[i]`; `out` is resized to match.
void predictForest(const Forest& forest, const FeatureImage& image,
                   const std::vector<Sample>& samples, const std::vector<Descriptor>& descriptors,
                   const PredictionParams& params, std::vector<Prediction>& out);

// Descriptors for all samples of a frame, in parallel.
void computeDescriptors(const FeatureImage& image, const std::vector<Sample>& samples,
                        DescriptorNormalisation normalisation, std::vector<Descriptor>& out);

}  // namespace relocalizer
