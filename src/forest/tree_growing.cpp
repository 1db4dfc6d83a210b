// Growing one tree: greedy splits that maximise information gain under a
// full-covariance Gaussian model of the labels, and leaves that hold the
// mean-shift modes of their labels with each mode's mean descriptor.

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <random>

#include "relocalizer/forest/training.h"

namespace relocalizer {

void LabelStats::add(const Eigen::Vector3f& x) {
  const double a = x.x(), b = x.y(), c = x.z();
  count += 1.0;
  sum += Eigen::Vector3d(a, b, c);
  square[0] += a * a;
  square[1] += a * b;
  square[2] += a * c;
  square[3] += b * b;
  square[4] += b * c;
  square[5] += c * c;
}

Eigen::Matrix3d LabelStats::covariance() const {
  if (count <= 0.0) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d mean = sum / count;
  Eigen::Matrix3d m;
  m << square[0], square[1], square[2], square[1], square[3], square[4], square[2], square[4],
      square[5];
  return m / count - mean * mean.transpose();
}

double gaussianEntropy(const Eigen::Matrix3d& sigma) {
  constexpr double kTwoPiE = 2.0 * M_PI * M_E;
  return 0.5 * std::log(kTwoPiE * kTwoPiE * kTwoPiE * sigma.determinant());
}

double LabelStats::entropy() const {
  // 1 mm^2 regulariser: below depth noise, so it only matters for degenerate sets.
  return gaussianEntropy(covariance() + 1e-6 * Eigen::Matrix3d::Identity());
}

namespace {

struct NodeTask {
  int32_t node;
  size_t begin, end;
  int depth;
};

// The best split found so far at a node; a split must gain more than `gain`.
struct SplitChoice {
  PixelFeature feature;
  float threshold = 0.0f;
  double gain = 1e-9;
  bool found = false;
};

class TreeGrower {
 public:
  TreeGrower(const std::vector<TrainingImage>& images, TreeSamples& samples,
             const ForestParams& params, DescriptorNormalisation descriptors, uint64_t seed,
             const TrainingProgress& progress);

  // Depth first, left before right, so node order (and the model's bytes)
  // follows from the seed alone.
  Tree grow();

 private:
  // Inlined into the loops that issue prefetches: called out of line, its
  // miss no longer overlaps with the prefetches (a point tree took 28 s
  // instead of 19).
  __attribute__((always_inline)) float evaluate(const PixelFeature& f,
                                                const TreeSamples::Item& item) const;

  // use(i, value) for every sample of items[0, n), with the pixel of the
  // sample some places ahead prefetched.
  template <typename Use>
  void forEachValue(const PixelFeature& feature, const TreeSamples::Item* items, size_t n,
                    Use use) const;

  PixelFeature randomFeature();

  // Splits the node's samples by the best of params_.feature_candidates random
  // features; false leaves it a leaf (too deep, too few samples, no gain, or a
  // child that would be too small).
  bool trySplit(const NodeTask& task, PixelFeature& best_feature, float& best_threshold,
                size_t& middle);

  // Splits are scored on a random subset of at most split_sample_cap samples,
  // moved to the front of the node's range; returns its size.
  size_t moveScoringSubsetToFront(const NodeTask& task);

  // Tries `feature` at thresholds drawn from its values on the subset. Labels
  // binned between sorted thresholds give every candidate split's child
  // statistics as running sums, so all thresholds cost one pass.
  void scoreFeature(const PixelFeature& feature, const NodeTask& task, size_t subset,
                    const LabelStats& parent, double parent_entropy, double min_side,
                    std::uniform_int_distribution<size_t>& pick_value, SplitChoice& best);

  // Samples with f < threshold first; returns where the right child starts.
  // `values`, when given, are f of every sample of the node, in order.
  size_t partition(const NodeTask& task, const PixelFeature& feature, float threshold,
                   const float* values);

  void makeLeaf(Tree& tree, const NodeTask& task);

  // The leaf's labels into points_ (and their items into members_); mean shift
  // is quadratic, so large leaves contribute a strided subset.
  void gatherLeafPoints(const NodeTask& task);

  // Per mode, the sum of the WHT descriptors of the samples assigned to it.
  std::vector<DescriptorF> modeDescriptorSums(size_t mode_count) const;

  // A mode at full precision, the covariance as its inverse (packed with the
  // tree once it is grown).
  static LeafMode leafMode(const Mode3D& mode);
  // A mode's descriptor: the sum of its samples' scaled as the model says, and quantised.
  Descriptor modeDescriptor(DescriptorF& descriptor_sum) const;

  const std::vector<TrainingImage>& images_;
  std::vector<TreeSamples::Item>& items_;
  const ForestParams& params_;
  const DescriptorNormalisation descriptors_;
  std::mt19937 rng_;
  const TrainingProgress& progress_;
  std::vector<FeatureImage> views_;
  std::vector<float> values_;
  // The best feature's values so far, when the subset is the whole node: its
  // partition then reads no image (at most split_sample_cap samples).
  std::vector<float> best_values_;
  // Each scoring sample's label as LabelStats of one sample: its products are
  // formed once per node instead of once per candidate feature, and adding it
  // to a bin is the same arithmetic as LabelStats::add of the label.
  std::vector<LabelStats> moments_;
  std::vector<uint32_t> bin_of_;
  std::vector<uint8_t> goes_left_;
  std::vector<float> thresholds_;
  std::vector<LabelStats> bins_;
  std::vector<Eigen::Vector3f> points_;
  std::vector<size_t> members_;
  std::vector<int> assignment_;
  // Every leaf's modes at full precision, packed on the tree's grid once the
  // tree is grown and the grid known.
  std::vector<LeafMode> leaf_modes_;
};

TreeGrower::TreeGrower(const std::vector<TrainingImage>& images, TreeSamples& samples,
                       const ForestParams& params, DescriptorNormalisation descriptors,
                       uint64_t seed, const TrainingProgress& progress)
    : images_(images),
      items_(samples.items),
      params_(params),
      descriptors_(descriptors),
      rng_(static_cast<uint32_t>(seed ^ (seed >> 32))),
      progress_(progress) {
  views_.reserve(images.size());
  for (const auto& image : images) views_.push_back(image.view());
  values_.resize(std::max(1, params.split_sample_cap));
  best_values_.resize(values_.size());
  moments_.resize(values_.size());
  bin_of_.resize(values_.size());
  thresholds_.resize(std::max(1, params.threshold_candidates));
  bins_.resize(thresholds_.size() + 1);
}

Tree TreeGrower::grow() {
  Tree tree;
  tree.nodes.emplace_back();
  std::vector<NodeTask> stack{{0, 0, items_.size(), 0}};
  while (!stack.empty()) {
    const NodeTask task = stack.back();
    stack.pop_back();
    PixelFeature feature;
    float threshold = 0.0f;
    size_t middle = 0;
    if (trySplit(task, feature, threshold, middle)) {
      const int32_t left = static_cast<int32_t>(tree.nodes.size());
      tree.nodes.emplace_back();
      tree.nodes.emplace_back();
      SplitNode& node = tree.nodes[task.node];
      node.feature = feature;
      node.threshold = threshold;
      node.left = left;
      // Right first so the left subtree is finished first (depth-first order).
      stack.push_back({left + 1, middle, task.end, task.depth + 1});
      stack.push_back({left, task.begin, middle, task.depth + 1});
    } else {
      makeLeaf(tree, task);
    }
  }
  packModes(leaf_modes_, tree.grid, tree.modes);
  return tree;
}

inline float TreeGrower::evaluate(const PixelFeature& f, const TreeSamples::Item& item) const {
  return evaluateFeature(f, views_[item.image], item.u, item.v, item.depth, item.colour.data());
}

template <typename Use>
void TreeGrower::forEachValue(const PixelFeature& feature, const TreeSamples::Item* items, size_t n,
                              Use use) const {
  // The samples' pixels are scattered over hundreds of images, nearly all
  // cache misses: prefetching kAhead samples ahead keeps several in flight.
  constexpr size_t kAhead = 16;
  for (size_t i = 0; i < n; ++i) {
    if (i + kAhead < n) {
      const TreeSamples::Item& ahead = items[i + kAhead];
      prefetchSecondPixel(feature, views_[ahead.image], ahead.u, ahead.v, ahead.depth);
    }
    use(i, evaluate(feature, items[i]));
  }
}

PixelFeature TreeGrower::randomFeature() {
  std::uniform_real_distribution<float> offset(-params_.max_offset, params_.max_offset);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> channel(0, 2);
  PixelFeature f;
  f.offset_u = static_cast<int16_t>(std::lround(offset(rng_)));
  f.offset_v = static_cast<int16_t>(std::lround(offset(rng_)));
  f.type = unit(rng_) < params_.depth_feature_share ? FeatureType::Depth : FeatureType::Colour;
  f.channel_p = static_cast<uint8_t>(channel(rng_));
  f.channel_q = static_cast<uint8_t>(channel(rng_));
  return f;
}

bool TreeGrower::trySplit(const NodeTask& task, PixelFeature& best_feature, float& best_threshold,
                          size_t& middle) {
  const size_t n = task.end - task.begin;
  const size_t min_leaf = static_cast<size_t>(std::max(1, params_.min_samples_leaf));
  if (task.depth >= params_.max_depth || n < 2 * min_leaf) return false;

  const size_t subset = moveScoringSubsetToFront(task);
  LabelStats parent;
  for (size_t i = 0; i < subset; ++i) {
    const Eigen::Vector3f& label = items_[task.begin + i].world;
    parent.add(label);
    moments_[i] = LabelStats{};
    moments_[i].add(label);
  }
  const double parent_entropy = parent.entropy();
  const double min_side =
      std::max(1.0, static_cast<double>(min_leaf) * static_cast<double>(subset) / n);

  SplitChoice best;
  std::uniform_int_distribution<size_t> pick_value(0, subset - 1);
  for (int c = 0; c < params_.feature_candidates; ++c)
    scoreFeature(randomFeature(), task, subset, parent, parent_entropy, min_side, pick_value, best);
  if (!best.found) return false;
  middle =
      partition(task, best.feature, best.threshold, subset == n ? best_values_.data() : nullptr);
  best_feature = best.feature;
  best_threshold = best.threshold;
  return middle - task.begin >= min_leaf && task.end - middle >= min_leaf;
}

size_t TreeGrower::moveScoringSubsetToFront(const NodeTask& task) {
  const size_t n = task.end - task.begin;
  const size_t subset = std::min(n, static_cast<size_t>(params_.split_sample_cap));
  if (subset < n) {
    for (size_t i = 0; i < subset; ++i) {
      std::uniform_int_distribution<size_t> pick(task.begin + i, task.end - 1);
      std::swap(items_[task.begin + i], items_[pick(rng_)]);
    }
  }
  return subset;
}

void TreeGrower::scoreFeature(const PixelFeature& feature, const NodeTask& task, size_t subset,
                              const LabelStats& parent, double parent_entropy, double min_side,
                              std::uniform_int_distribution<size_t>& pick_value,
                              SplitChoice& best) {
  forEachValue(feature, items_.data() + task.begin, subset,
               [this](size_t i, float value) { values_[i] = value; });
  const size_t t_count = thresholds_.size();
  for (size_t t = 0; t < t_count; ++t) thresholds_[t] = values_[pick_value(rng_)];
  std::sort(thresholds_.begin(), thresholds_.end());
  for (auto& bin : bins_) bin = LabelStats{};
  // Bin b holds values in [thresholds[b-1], thresholds[b]); "v < thresholds[k]"
  // (go left) is then "bin <= k". The bin is the upper_bound index, counted
  // without branches (a binary search over random values mispredicts half its
  // branches); the same for every value, as feature values are never NaN.
  const float* thresholds = thresholds_.data();
  for (size_t i = 0; i < subset; ++i) {
    const float value = values_[i];
    unsigned bin = 0;
    for (size_t t = 0; t < t_count; ++t) bin += thresholds[t] <= value ? 1u : 0u;
    bin_of_[i] = bin;
  }
  for (size_t i = 0; i < subset; ++i) bins_[bin_of_[i]].add(moments_[i]);
  LabelStats left;
  bool kept_values = false;
  for (size_t k = 0; k < t_count; ++k) {
    left.add(bins_[k]);
    if (k + 1 < t_count && thresholds_[k + 1] == thresholds_[k]) continue;
    const double right_count = parent.count - left.count;
    if (left.count < min_side || right_count < min_side) continue;
    LabelStats right = parent;
    right.count = right_count;
    right.sum -= left.sum;
    for (int j = 0; j < 6; ++j) right.square[j] -= left.square[j];
    const double gain = parent_entropy - (left.count / parent.count) * left.entropy() -
                        (right_count / parent.count) * right.entropy();
    if (gain > best.gain) {
      if (!kept_values && subset == task.end - task.begin) {
        std::copy(values_.begin(), values_.begin() + subset, best_values_.begin());
        kept_values = true;
      }
      best.gain = gain;
      best.feature = feature;
      best.threshold = thresholds_[k];
      best.found = true;
    }
  }
}

size_t TreeGrower::partition(const NodeTask& task, const PixelFeature& feature, float threshold,
                             const float* values) {
  // Each sample's side first, with the same prefetching as the split search,
  // then a two-ended swap pass over the sides: the moves std::partition makes,
  // as it too tests each sample once, so the order (and the tree) is the same.
  const size_t n = task.end - task.begin;
  TreeSamples::Item* items = items_.data() + task.begin;
  goes_left_.resize(n);
  if (values)
    for (size_t i = 0; i < n; ++i) goes_left_[i] = values[i] < threshold;
  else
    forEachValue(feature, items, n,
                 [this, threshold](size_t i, float value) { goes_left_[i] = value < threshold; });
  size_t first = 0, last = n;
  while (true) {
    while (first != last && goes_left_[first]) ++first;
    if (first == last) break;
    --last;
    while (first != last && !goes_left_[last]) --last;
    if (first == last) break;
    std::swap(items[first], items[last]);
    std::swap(goes_left_[first], goes_left_[last]);
    ++first;
  }
  return task.begin + first;
}

void TreeGrower::makeLeaf(Tree& tree, const NodeTask& task) {
  gatherLeafPoints(task);
  const std::vector<Mode3D> modes = meanShiftModes(points_, params_.mean_shift, &assignment_);
  std::vector<DescriptorF> descriptors = modeDescriptorSums(modes.size());
  LeafRange range;
  range.first_mode = static_cast<uint32_t>(leaf_modes_.size());
  range.mode_count = static_cast<uint32_t>(modes.size());
  for (size_t m = 0; m < modes.size(); ++m) {
    leaf_modes_.push_back(leafMode(modes[m]));
    tree.descriptors.push_back(modeDescriptor(descriptors[m]));
  }
  tree.nodes[task.node] = SplitNode::leaf(range);
  if (progress_.samples_done) progress_.samples_done(task.end - task.begin);
}

void TreeGrower::gatherLeafPoints(const NodeTask& task) {
  const size_t n = task.end - task.begin;
  constexpr size_t kMaxLeafPoints = 600;
  const size_t stride = std::max<size_t>(1, (n + kMaxLeafPoints - 1) / kMaxLeafPoints);
  points_.clear();
  members_.clear();
  for (size_t i = task.begin; i < task.end; i += stride) {
    points_.push_back(items_[i].world);
    members_.push_back(i);
  }
}

std::vector<DescriptorF> TreeGrower::modeDescriptorSums(size_t mode_count) const {
  std::vector<DescriptorF> sums(mode_count);
  for (auto& d : sums) d.fill(0.0f);
  for (size_t k = 0; k < members_.size(); ++k) {
    const int m = assignment_[k];
    if (m < 0) continue;
    const auto& item = items_[members_[k]];
    const DescriptorF d = computeDescriptor(views_[item.image], item.u, item.v, descriptors_);
    for (int j = 0; j < kDescriptorSize; ++j) sums[m][j] += d[j];
  }
  return sums;
}

LeafMode TreeGrower::leafMode(const Mode3D& mode) {
  LeafMode out;
  out.mean = mode.mean;
  out.setCovariance(mode.covariance);
  return out;
}

Descriptor TreeGrower::modeDescriptor(DescriptorF& descriptor_sum) const {
  normaliseDescriptor(descriptor_sum, descriptors_);
  return quantizeDescriptor(descriptor_sum);
}

}  // namespace

Tree growTree(const std::vector<TrainingImage>& images, TreeSamples& samples,
              const ForestParams& params, DescriptorNormalisation descriptors, uint64_t seed,
              const TrainingProgress& progress) {
  if (samples.items.empty()) {
    // No data (e.g. no line segments at all): a single leaf without modes.
    Tree tree;
    tree.nodes.push_back(SplitNode::leaf({0, 0}));
    return tree;
  }
  return TreeGrower(images, samples, params, descriptors, seed, progress).grow();
}

}  // namespace relocalizer
