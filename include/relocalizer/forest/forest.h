#pragma once
// Regression forests mapping a pixel to world coordinates, stored as flat
// arrays (nodes, leaf ranges, modes) so prediction touches contiguous memory
// and a model loads with a handful of reads. Prediction backtracks through up
// to `max_leaves` leaves per tree, visiting the untaken branches in order of
// |f - tau| (how narrowly the sample missed them), and keeps, per tree, the
// mode whose descriptor is nearest to the sample's.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "relocalizer/forest/features.h"
#include "relocalizer/forest/sampling.h"

namespace relocalizer {

// One mean-shift mode of the world coordinates that reached a leaf. A plain
// fixed-size struct: leaves are ranges into one array of these.
struct LeafMode {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();  // world, metres
  float support = 0.0f;  // training samples assigned to the mode
  // Inverse covariance, upper triangle (xx xy xz yy yz zz), 1/m^2: what the
  // Mahalanobis distances in RANSAC and refinement need.
  std::array<float, 6> information{};
  float log_det_covariance = 0.0f;
  Descriptor descriptor{};  // mean WHT descriptor of the mode's samples

  Eigen::Matrix3f informationMatrix() const;
  Eigen::Matrix3f covariance() const;
  void setCovariance(const Eigen::Matrix3f& covariance);
  // (x - mean)^T Sigma^-1 (x - mean)
  float mahalanobisSquared(const Eigen::Vector3f& x) const {
    const Eigen::Vector3f d = x - mean;
    const auto& s = information;
    return s[0] * d.x() * d.x() + s[3] * d.y() * d.y() + s[5] * d.z() * d.z() +
           2.0f * (s[1] * d.x() * d.y() + s[2] * d.x() * d.z() + s[4] * d.y() * d.z());
  }
};

struct SplitNode {
  PixelFeature feature;
  float threshold = 0.0f;  // f < threshold goes left
  // >= 0: index of the left child (the right child follows it);
  // < 0: this node is leaf number -(left + 1).
  int32_t left = -1;

  bool isLeaf() const { return left < 0; }
  int32_t leafIndex() const { return -(left + 1); }  // no overflow at INT32_MIN
  static int32_t encodeLeaf(int32_t leaf) { return -leaf - 1; }
};
static_assert(sizeof(SplitNode) == 16, "SplitNode layout is part of the model format");

struct LeafRange {
  uint32_t first_mode = 0;
  uint32_t mode_count = 0;
};

struct Tree {
  std::vector<SplitNode> nodes;  // nodes[0] is the root
  std::vector<LeafRange> leaves;
  std::vector<LeafMode> modes;

  int depth() const;
  // Leaf reached by plain descent (no backtracking).
  int32_t descend(const FeatureImage& image, int u, int v, float depth) const;
};

struct Forest {
  std::vector<Tree> trees;
  bool empty() const { return trees.empty(); }
  size_t nodeCount() const;
  size_t leafCount() const;
  size_t modeCount() const;
};

constexpr int kMaxTrees = 16;

struct ModeCandidate {
  const LeafMode* mode = nullptr;
  int32_t descriptor_distance = 0;
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

// Predictions for every sample, in parallel over samples. `descriptors[i]`
// belongs to `samples[i]`; `out` is resized to match.
void predictForest(const Forest& forest, const FeatureImage& image,
                   const std::vector<Sample>& samples, const std::vector<Descriptor>& descriptors,
                   const PredictionParams& params, std::vector<Prediction>& out);

// Descriptors for all samples of a frame, in parallel.
void computeDescriptors(const FeatureImage& image, const std::vector<Sample>& samples,
                        std::vector<Descriptor>& out);

}  // namespace relocalizer
