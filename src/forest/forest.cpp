#include "relocalizer/forest/forest.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <algorithm>
#include <limits>

namespace relocalizer {

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

size_t Tree::leafCount() const {
  return static_cast<size_t>(
      std::count_if(nodes.begin(), nodes.end(), [](const SplitNode& n) { return n.isLeaf(); }));
}

LeafRange Tree::descend(const FeatureImage& image, int u, int v, float depth) const {
  const FeatureSite site = FeatureSite::at(u, v, depth);
  int32_t index = 0;
  while (!nodes[index].isLeaf()) {
    const SplitNode& node = nodes[index];
    index = node.left + (evaluateFeature(node.feature, image, site) < node.threshold ? 0 : 1);
  }
  return nodes[index].leafModes();
}

size_t Forest::nodeCount() const {
  size_t n = 0;
  for (const auto& t : trees) n += t.nodes.size();
  return n;
}
size_t Forest::leafCount() const {
  size_t n = 0;
  for (const auto& t : trees) n += t.leafCount();
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
  BranchQueue() = default;
  explicit BranchQueue(int capacity) { reset(capacity); }
  void reset(int capacity) {
    capacity_ = std::clamp(capacity, 0, kMaxCapacity);
    size_ = 0;
  }
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
  int capacity_ = 0;
  int size_ = 0;
};

// One step of a descent at a split node: the child to take, and the sibling
// queued for backtracking by how narrowly the sample missed it.
inline int32_t splitStep(const std::vector<SplitNode>& nodes, int32_t index,
                         const FeatureImage& image, const FeatureSite& site, int max_leaves,
                         BranchQueue& queue) {
  const SplitNode& node = nodes[index];
  // Start fetching both children while the feature reads the image: deep
  // nodes are rarely cached, and this overlaps the two memory latencies.
  __builtin_prefetch(&nodes[node.left]);
  __builtin_prefetch(&nodes[node.left + 1]);
  const float f = evaluateFeature(node.feature, image, site);
  const bool go_left = f < node.threshold;
  if (max_leaves > 1) queue.push(std::abs(f - node.threshold), node.left + (go_left ? 1 : 0));
  return node.left + (go_left ? 0 : 1);
}

// The nearest mode of the leaves visited so far, by index into its tree's
// modes: only the one kept is unpacked (candidateOf).
struct NearestMode {
  int32_t mode = -1;
  int32_t distance = ModeCandidate::kNoDescriptorDistance;
};

// Keeps the nearest mode of `range` in `best` (the first of equals).
inline void nearestMode(const Tree& tree, const LeafRange& range, const Descriptor& descriptor,
                        NearestMode& best) {
  for (uint32_t m = range.first_mode; m < range.first_mode + range.mode_count; ++m) {
    const int32_t d = descriptorDistance(tree.descriptors[m], descriptor);
    if (d < best.distance) {
      best.distance = d;
      best.mode = static_cast<int32_t>(m);
    }
  }
}

ModeCandidate candidateOf(const Tree& tree, const NearestMode& nearest) {
  ModeCandidate candidate;
  if (nearest.mode < 0) return candidate;
  candidate.mode = tree.mode(static_cast<uint32_t>(nearest.mode));
  candidate.descriptor_distance = nearest.distance;
  return candidate;
}

// predictInTree for many samples at once. A single descent is a chain of
// dependent cache misses (each node's address comes from its parent, and a
// model of tens of MB does not fit the cache), so one sample at a time leaves
// the core waiting on DRAM. Here kLanes samples advance in turn, one memory
// access each per round (a node, a leaf's modes' descriptors, or the chosen
// mode) with the next access prefetched, so up to kLanes misses are in flight;
// a split node takes two turns, the second reading the pixel the first located
// and prefetched. Each lane runs exactly predictInTree's steps in its order, so
// every candidate is the one predictInTree gives. Writes candidates[slot] of
// each prediction.
class LockStepDescent {
 public:
  static constexpr int kLanes = 16;

  LockStepDescent(const Tree& tree, const FeatureImage& image, int max_leaves)
      : tree_(tree), image_(image), max_leaves_(max_leaves) {}

  void run(const Sample* samples, const Descriptor* descriptors, size_t count, Prediction* out,
           int slot) {
    samples_ = samples;
    descriptors_ = descriptors;
    count_ = count;
    out_ = out;
    slot_ = slot;
    next_ = 0;
    int active = 0;
    for (Lane& lane : lanes_) active += start(lane) ? 1 : 0;
    while (active > 0)
      for (Lane& lane : lanes_)
        if (lane.step != Step::Idle && !advance(lane)) active -= start(lane) ? 0 : 1;
  }

 private:
  enum class Step : uint8_t { Descend, Split, Modes, Unpack, Idle };
  struct Lane {
    BranchQueue queue;
    size_t sample = 0;
    FeatureSite site;
    int32_t node = 0;
    int qu = 0, qv = 0;  // the second pixel of `node`'s feature (Split)
    LeafRange range;
    int visited = 0;
    NearestMode best;
    Step step = Step::Idle;
  };

  // Gives the lane the next sample; false when none is left.
  bool start(Lane& lane) {
    if (next_ >= count_) {
      lane.step = Step::Idle;
      return false;
    }
    lane.sample = next_++;
    const Sample& sample = samples_[lane.sample];
    lane.site = FeatureSite::at(sample.u, sample.v, sample.depth);
    lane.node = 0;
    lane.visited = 0;
    lane.queue.reset(max_leaves_ - 1);
    lane.best = NearestMode{};
    lane.step = Step::Descend;
    return true;
  }

  // One memory access of the lane; false when its sample is done (and
  // written).
  bool advance(Lane& lane) {
    const std::vector<SplitNode>& nodes = tree_.nodes;
    switch (lane.step) {
      case Step::Descend:
        if (!nodes[lane.node].isLeaf()) {
          // The second pixel's address is known only now; it is read on the
          // lane's next turn (Split), once the other lanes' steps have
          // hidden its latency.
          const SplitNode& node = nodes[lane.node];
          __builtin_prefetch(&nodes[node.left]);
          __builtin_prefetch(&nodes[node.left + 1]);
          secondPixel(node.feature, image_, lane.site, lane.qu, lane.qv);
          prefetchPixel(node.feature, image_, lane.qu, lane.qv);
          lane.step = Step::Split;
        } else {
          lane.range = nodes[lane.node].leafModes();
          const LeafRange& r = lane.range;
          for (uint32_t m = r.first_mode; m < r.first_mode + r.mode_count; ++m) {
            const char* descriptor = reinterpret_cast<const char*>(tree_.descriptors[m].data());
            __builtin_prefetch(descriptor);
            __builtin_prefetch(descriptor + sizeof(Descriptor) - 1);
          }
          lane.step = Step::Modes;
        }
        return true;
      case Step::Split: {
        const SplitNode& node = nodes[lane.node];
        const FeatureSite& p = lane.site;
        const float f =
            featureValueAt(node.feature, image_, p,
                           image_.colour + p.v * image_.colour_stride + p.u * 3, lane.qu, lane.qv);
        const bool go_left = f < node.threshold;
        if (max_leaves_ > 1)
          lane.queue.push(std::abs(f - node.threshold), node.left + (go_left ? 1 : 0));
        lane.node = node.left + (go_left ? 0 : 1);
        lane.step = Step::Descend;
        return true;
      }
      case Step::Modes:
        nearestMode(tree_, lane.range, descriptors_[lane.sample], lane.best);
        ++lane.visited;
        if (lane.visited >= std::max(1, max_leaves_) || lane.queue.empty()) {
          // The chosen mode is unpacked on the lane's next turn, its read
          // overlapped with the other lanes' like every other.
          if (lane.best.mode >= 0) __builtin_prefetch(&tree_.modes[lane.best.mode]);
          lane.step = Step::Unpack;
          return true;
        }
        lane.node = lane.queue.pop();
        __builtin_prefetch(&nodes[lane.node]);
        lane.step = Step::Descend;
        return true;
      case Step::Unpack:
        out_[lane.sample].candidates[slot_] = candidateOf(tree_, lane.best);
        return false;
      case Step::Idle:
        break;
    }
    return false;
  }

  const Tree& tree_;
  const FeatureImage& image_;
  const int max_leaves_;
  std::array<Lane, kLanes> lanes_;
  const Sample* samples_ = nullptr;
  const Descriptor* descriptors_ = nullptr;
  size_t count_ = 0;
  size_t next_ = 0;
  Prediction* out_ = nullptr;
  int slot_ = 0;
};

}  // namespace

ModeCandidate predictInTree(const Tree& tree, const FeatureImage& image, const Sample& sample,
                            const Descriptor& descriptor, int max_leaves) {
  NearestMode best;
  if (tree.nodes.empty()) return {};
  BranchQueue queue(max_leaves - 1);
  const FeatureSite site = FeatureSite::at(sample.u, sample.v, sample.depth);
  int32_t start = 0;
  for (int visited = 0; visited < std::max(1, max_leaves); ++visited) {
    int32_t index = start;
    while (!tree.nodes[index].isLeaf())
      index = splitStep(tree.nodes, index, image, site, max_leaves, queue);
    nearestMode(tree, tree.nodes[index].leafModes(), descriptor, best);
    if (queue.empty()) break;
    start = queue.pop();
  }
  return candidateOf(tree, best);
}

void predictForest(const Forest& forest, const FeatureImage& image,
                   const std::vector<Sample>& samples, const std::vector<Descriptor>& descriptors,
                   const PredictionParams& params, std::vector<Prediction>& out) {
  out.resize(samples.size());
  const int trees = std::min<int>(static_cast<int>(forest.trees.size()), kMaxTrees);
  // Blocks of several lane-fills, so that lanes stay busy while a block drains.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 8 * LockStepDescent::kLanes),
                    [&](const tbb::blocked_range<size_t>& range) {
                      const size_t first = range.begin(), count = range.size();
                      for (int t = 0; t < trees; ++t) {
                        if (forest.trees[t].nodes.empty()) {
                          for (size_t i = first; i < range.end(); ++i)
                            out[i].candidates[t] = ModeCandidate{};
                          continue;
                        }
                        LockStepDescent(forest.trees[t], image, params.max_leaves)
                            .run(samples.data() + first, descriptors.data() + first, count,
                                 out.data() + first, t);
                      }
                      // One candidate per tree that had a mode, in tree order.
                      for (size_t i = first; i < range.end(); ++i) {
                        Prediction& p = out[i];
                        p.count = 0;
                        for (int t = 0; t < trees; ++t)
                          if (p.candidates[t].found()) p.candidates[p.count++] = p.candidates[t];
                      }
                    });
}

void computeDescriptors(const FeatureImage& image, const std::vector<Sample>& samples,
                        DescriptorNormalisation normalisation, std::vector<Descriptor>& out) {
  out.resize(samples.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 128),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t i = range.begin(); i < range.end(); ++i)
                        out[i] = quantizeDescriptor(
                            computeDescriptor(image, samples[i].u, samples[i].v, normalisation));
                    });
}

}  // namespace relocalizer
