#include "relocalizer/forest/forest.h"

#include <Eigen/LU>
#include <algorithm>
#include <limits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace relocalizer {

Eigen::Matrix3f LeafMode::informationMatrix() const {
  const auto& s = information;
  Eigen::Matrix3f m;
  m << s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5];
  return m;
}

Eigen::Matrix3f LeafMode::covariance() const { return informationMatrix().inverse(); }

void LeafMode::setCovariance(const Eigen::Matrix3f& covariance) {
  const Eigen::Matrix3f inverse = covariance.inverse();
  information = {inverse(0, 0), inverse(0, 1), inverse(0, 2), inverse(1, 1), inverse(1, 2),
                 inverse(2, 2)};
  log_det_covariance = std::log(std::max(covariance.determinant(), 1e-30f));
}

int Tree::depth() const {
  if (nodes.empty()) return 0;
  // Children always follow their parent, so one forward pass suffices.
  std::vector<int> level(nodes.size(), 0);
  int deepest = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    deepest = std::max(deepest, level[i]);
    if (!nodes[i].isLeaf()) {
      level[nodes[i].left] = level[i] + 1;
      level[nodes[i].left + 1] = level[i] + 1;
    }
  }
  return deepest;
}

int32_t Tree::descend(const FeatureImage& image, int u, int v, float depth) const {
  int32_t index = 0;
  while (!nodes[index].isLeaf()) {
    const SplitNode& node = nodes[index];
    index = node.left + (evaluateFeature(node.feature, image, u, v, depth) < node.threshold ? 0 : 1);
  }
  return nodes[index].leafIndex();
}

size_t Forest::nodeCount() const {
  size_t n = 0;
  for (const auto& t : trees) n += t.nodes.size();
  return n;
}
size_t Forest::leafCount() const {
  size_t n = 0;
  for (const auto& t : trees) n += t.leaves.size();
  return n;
}
size_t Forest::modeCount() const {
  size_t n = 0;
  for (const auto& t : trees) n += t.modes.size();
  return n;
}

namespace {

// The untaken branches still worth visiting, smallest |f - tau| first. Only
// the `remaining` smallest can ever be popped (each pop takes the smallest, and
// later pushes only add entries), so at most max_leaves - 1 are kept, in a
// small sorted array: most pushes are rejected with one comparison, and
// nothing is allocated per sample.
class BranchQueue {
 public:
  explicit BranchQueue(int capacity) : capacity_(std::min(capacity, kMaxCapacity)) {}
  bool empty() const { return size_ == 0; }
  void push(float priority, int32_t node) {
    if (capacity_ == 0 || (size_ == capacity_ && priority >= entries_[size_ - 1].priority)) return;
    int i = size_ < capacity_ ? size_++ : size_ - 1;
    while (i > 0 && entries_[i - 1].priority > priority) {
      entries_[i] = entries_[i - 1];
      --i;
    }
    entries_[i] = {priority, node};
  }
  // Removes and returns the smallest; the capacity shrinks with the pops left.
  int32_t pop() {
    const int32_t top = entries_[0].node;
    for (int i = 1; i < size_; ++i) entries_[i - 1] = entries_[i];
    --size_;
    capacity_ = std::max(capacity_ - 1, 0);
    size_ = std::min(size_, capacity_);
    return top;
  }

 private:
  struct Entry {
    float priority;
    int32_t node;
  };
  static constexpr int kMaxCapacity = 64;
  std::array<Entry, kMaxCapacity> entries_;
  int capacity_;
  int size_ = 0;
};

}  // namespace

ModeCandidate predictInTree(const Tree& tree, const FeatureImage& image, const Sample& sample,
                            const Descriptor& descriptor, int max_leaves) {
  ModeCandidate best;
  best.descriptor_distance = std::numeric_limits<int32_t>::max();
  if (tree.nodes.empty()) return best;
  BranchQueue queue(max_leaves - 1);
  int32_t start = 0;
  for (int visited = 0; visited < std::max(1, max_leaves); ++visited) {
    int32_t index = start;
    while (!tree.nodes[index].isLeaf()) {
      const SplitNode& node = tree.nodes[index];
      // Start fetching both children while the feature reads the image: deep
      // nodes are rarely cached, and this overlaps the two memory latencies.
      __builtin_prefetch(&tree.nodes[node.left]);
      __builtin_prefetch(&tree.nodes[node.left + 1]);
      const float f = evaluateFeature(node.feature, image, sample.u, sample.v, sample.depth);
      const bool go_left = f < node.threshold;
      if (max_leaves > 1) queue.push(std::abs(f - node.threshold), node.left + (go_left ? 1 : 0));
      index = node.left + (go_left ? 0 : 1);
    }
    const LeafRange& leaf = tree.leaves[tree.nodes[index].leafIndex()];
    for (uint32_t m = leaf.first_mode; m < leaf.first_mode + leaf.mode_count; ++m) {
      const int32_t d = descriptorDistance(tree.modes[m].descriptor, descriptor);
      if (d < best.descriptor_distance) {
        best.descriptor_distance = d;
        best.mode = &tree.modes[m];
      }
    }
    if (queue.empty()) break;
    start = queue.pop();
  }
  return best;
}

void predictForest(const Forest& forest, const FeatureImage& image,
                   const std::vector<Sample>& samples, const std::vector<Descriptor>& descriptors,
                   const PredictionParams& params, std::vector<Prediction>& out) {
  out.resize(samples.size());
  const int trees = std::min<int>(static_cast<int>(forest.trees.size()), kMaxTrees);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 64),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t i = range.begin(); i < range.end(); ++i) {
                        Prediction& p = out[i];
                        p.count = 0;
                        for (int t = 0; t < trees; ++t) {
                          const ModeCandidate c = predictInTree(forest.trees[t], image, samples[i],
                                                                descriptors[i], params.max_leaves);
                          if (c.mode) p.candidates[p.count++] = c;
                        }
                      }
                    });
}

void computeDescriptors(const FeatureImage& image, const std::vector<Sample>& samples,
                        std::vector<Descriptor>& out) {
  out.resize(samples.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 128),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t i = range.begin(); i < range.end(); ++i)
                        out[i] = quantizeDescriptor(
                            computeDescriptor(image, samples[i].u, samples[i].v));
                    });
}

}  // namespace relocalizer
