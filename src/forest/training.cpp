#include "relocalizer/training.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace relocalizer {

const char* forestKindName(ForestKind kind) {
  return kind == ForestKind::Points ? "points" : "lines";
}

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

void LabelStats::add(const LabelStats& other) {
  count += other.count;
  sum += other.sum;
  for (int i = 0; i < 6; ++i) square[i] += other.square[i];
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

uint64_t treeSeed(uint64_t seed, ForestKind kind, int tree) {
  // splitmix64 over the combined key: well-mixed, independent streams.
  uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (1 + static_cast<uint64_t>(tree) +
                                              (kind == ForestKind::Lines ? 1000 : 0));
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

namespace {

std::vector<int> chooseImages(int total, int wanted, std::mt19937& rng) {
  std::vector<int> all(total);
  std::iota(all.begin(), all.end(), 0);
  if (wanted >= total) return all;
  for (int i = 0; i < wanted; ++i) {
    std::uniform_int_distribution<int> pick(i, total - 1);
    std::swap(all[i], all[pick(rng)]);
  }
  all.resize(wanted);
  std::sort(all.begin(), all.end());
  return all;
}

TreeSamples::Item makeItem(int image, const Sample& s, const Pose& pose) {
  TreeSamples::Item item;
  item.image = image;
  item.u = s.u;
  item.v = s.v;
  item.depth = s.depth;
  item.world = (pose.cast<float>() * s.camera_point);
  return item;
}

RgbdFrame asFrame(const TrainingImage& image) {
  RgbdFrame frame;
  frame.colour = image.colour;
  frame.depth = image.depth;
  frame.camera = image.camera;
  return frame;
}

}  // namespace

std::vector<TreeSamples> drawTreeSamples(const std::vector<TrainingImage>& images, ForestKind kind,
                                         const TrainingParams& params) {
  const ForestParams& forest = kind == ForestKind::Points ? params.points : params.lines;
  const int n_images = static_cast<int>(images.size());
  std::vector<LineSamples> line_cache;
  if (kind == ForestKind::Lines) {
    line_cache.resize(n_images);
    tbb::parallel_for(0, n_images, [&](int i) {
      std::mt19937 rng(static_cast<uint32_t>(treeSeed(params.seed, kind, 100000 + i)));
      line_cache[i] = sampleLines(asFrame(images[i]), params.line_sampling, 0, rng);
    });
  }
  std::vector<TreeSamples> trees(forest.trees);
  tbb::parallel_for(0, forest.trees, [&](int t) {
    std::mt19937 rng(static_cast<uint32_t>(treeSeed(params.seed, kind, t)));
    const std::vector<int> chosen = chooseImages(n_images, forest.images_per_tree, rng);
    std::vector<Sample> drawn;
    for (int i : chosen) {
      drawn.clear();
      if (kind == ForestKind::Points) {
        samplePoints(asFrame(images[i]), forest.samples_per_image, rng, drawn);
      } else {
        const auto& all = line_cache[i].samples;
        const int take = std::min<int>(forest.samples_per_image, static_cast<int>(all.size()));
        std::vector<int> order(all.size());
        std::iota(order.begin(), order.end(), 0);
        for (int k = 0; k < take; ++k) {
          std::uniform_int_distribution<int> pick(k, static_cast<int>(order.size()) - 1);
          std::swap(order[k], order[pick(rng)]);
          drawn.push_back(all[order[k]]);
        }
      }
      for (const Sample& s : drawn) trees[t].items.push_back(makeItem(i, s, images[i].pose));
    }
  });
  return trees;
}

namespace {

struct NodeTask {
  int32_t node;
  size_t begin, end;
  int depth;
};

class TreeGrower {
 public:
  TreeGrower(const std::vector<TrainingImage>& images, TreeSamples& samples,
             const ForestParams& params, uint64_t seed, const TrainingProgress& progress)
      : images_(images),
        items_(samples.items),
        params_(params),
        rng_(static_cast<uint32_t>(seed ^ (seed >> 32))),
        progress_(progress) {
    views_.reserve(images.size());
    for (const auto& image : images) views_.push_back(image.view());
    values_.resize(std::max(1, params.split_sample_cap));
    thresholds_.resize(std::max(1, params.threshold_candidates));
    bins_.resize(thresholds_.size() + 1);
  }

  Tree grow() {
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
    return tree;
  }

 private:
  float evaluate(const PixelFeature& f, const TreeSamples::Item& item) const {
    return evaluateFeature(f, views_[item.image], item.u, item.v, item.depth);
  }

  PixelFeature randomFeature() {
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

  bool trySplit(const NodeTask& task, PixelFeature& best_feature, float& best_threshold,
                size_t& middle) {
    const size_t n = task.end - task.begin;
    const size_t min_leaf = static_cast<size_t>(std::max(1, params_.min_samples_leaf));
    if (task.depth >= params_.max_depth || n < 2 * min_leaf) return false;

    // Score splits on a random subset at the front of the node's range.
    const size_t subset = std::min(n, static_cast<size_t>(params_.split_sample_cap));
    if (subset < n) {
      for (size_t i = 0; i < subset; ++i) {
        std::uniform_int_distribution<size_t> pick(task.begin + i, task.end - 1);
        std::swap(items_[task.begin + i], items_[pick(rng_)]);
      }
    }
    LabelStats parent;
    for (size_t i = 0; i < subset; ++i) parent.add(items_[task.begin + i].world);
    const double parent_entropy = parent.entropy();
    const double min_side =
        std::max(1.0, static_cast<double>(min_leaf) * static_cast<double>(subset) / n);

    double best_gain = 1e-9;
    bool found = false;
    std::uniform_int_distribution<size_t> pick_value(0, subset - 1);
    for (int c = 0; c < params_.feature_candidates; ++c) {
      const PixelFeature feature = randomFeature();
      for (size_t i = 0; i < subset; ++i) values_[i] = evaluate(feature, items_[task.begin + i]);
      const size_t t_count = thresholds_.size();
      for (size_t t = 0; t < t_count; ++t) thresholds_[t] = values_[pick_value(rng_)];
      std::sort(thresholds_.begin(), thresholds_.end());
      for (auto& bin : bins_) bin = LabelStats{};
      for (size_t i = 0; i < subset; ++i) {
        // Bin b holds values in [thresholds[b-1], thresholds[b]); "v < thresholds[k]"
        // (go left) is then "bin <= k".
        const size_t bin =
            std::upper_bound(thresholds_.begin(), thresholds_.end(), values_[i]) - thresholds_.begin();
        bins_[bin].add(items_[task.begin + i].world);
      }
      LabelStats left;
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
        if (gain > best_gain) {
          best_gain = gain;
          best_feature = feature;
          best_threshold = thresholds_[k];
          found = true;
        }
      }
    }
    if (!found) return false;
    const auto first = items_.begin() + static_cast<std::ptrdiff_t>(task.begin);
    const auto last = items_.begin() + static_cast<std::ptrdiff_t>(task.end);
    const auto split = std::partition(first, last, [&](const TreeSamples::Item& item) {
      return evaluate(best_feature, item) < best_threshold;
    });
    middle = static_cast<size_t>(split - items_.begin());
    return middle - task.begin >= min_leaf && task.end - middle >= min_leaf;
  }

  void makeLeaf(Tree& tree, const NodeTask& task) {
    const size_t n = task.end - task.begin;
    // Mean shift is quadratic; a strided subset of large leaves is plenty.
    constexpr size_t kMaxLeafPoints = 600;
    const size_t stride = std::max<size_t>(1, (n + kMaxLeafPoints - 1) / kMaxLeafPoints);
    points_.clear();
    members_.clear();
    for (size_t i = task.begin; i < task.end; i += stride) {
      points_.push_back(items_[i].world);
      members_.push_back(i);
    }
    const std::vector<Mode3D> modes = meanShiftModes(points_, params_.mean_shift, &assignment_);
    std::vector<DescriptorF> descriptor_sums(modes.size());
    for (auto& d : descriptor_sums) d.fill(0.0f);
    for (size_t k = 0; k < members_.size(); ++k) {
      const int m = assignment_[k];
      if (m < 0) continue;
      const auto& item = items_[members_[k]];
      const DescriptorF d = computeDescriptor(views_[item.image], item.u, item.v);
      for (int j = 0; j < kDescriptorSize; ++j) descriptor_sums[m][j] += d[j];
    }
    LeafRange range;
    range.first_mode = static_cast<uint32_t>(tree.modes.size());
    range.mode_count = static_cast<uint32_t>(modes.size());
    for (size_t m = 0; m < modes.size(); ++m) {
      LeafMode mode;
      mode.mean = modes[m].mean;
      mode.support = static_cast<float>(modes[m].support * stride);
      mode.setCovariance(modes[m].covariance);
      DescriptorF& d = descriptor_sums[m];
      float norm = 0.0f;
      for (float x : d) norm += x * x;
      if (norm > 0.0f)
        for (float& x : d) x /= std::sqrt(norm);
      mode.descriptor = quantizeDescriptor(d);
      tree.modes.push_back(mode);
    }
    tree.nodes[task.node].left = SplitNode::encodeLeaf(static_cast<int32_t>(tree.leaves.size()));
    tree.leaves.push_back(range);
    if (progress_.samples_done) progress_.samples_done(n);
  }

  const std::vector<TrainingImage>& images_;
  std::vector<TreeSamples::Item>& items_;
  const ForestParams& params_;
  std::mt19937 rng_;
  const TrainingProgress& progress_;
  std::vector<FeatureImage> views_;
  std::vector<float> values_;
  std::vector<float> thresholds_;
  std::vector<LabelStats> bins_;
  std::vector<Eigen::Vector3f> points_;
  std::vector<size_t> members_;
  std::vector<int> assignment_;
};

}  // namespace

Tree growTree(const std::vector<TrainingImage>& images, TreeSamples& samples,
              const ForestParams& params, uint64_t seed, const TrainingProgress& progress) {
  if (samples.items.empty()) {
    // No data (e.g. no line segments at all): a single leaf without modes.
    Tree tree;
    tree.nodes.emplace_back();
    tree.nodes[0].left = SplitNode::encodeLeaf(0);
    tree.leaves.push_back({0, 0});
    return tree;
  }
  return TreeGrower(images, samples, params, seed, progress).grow();
}

Forest trainForest(const std::vector<TrainingImage>& images, ForestKind kind,
                   const TrainingParams& params, const TrainingProgress& progress) {
  const ForestParams& forest_params = kind == ForestKind::Points ? params.points : params.lines;
  std::vector<TreeSamples> samples = drawTreeSamples(images, kind, params);
  if (progress.samples_drawn) {
    size_t total = 0;
    for (const auto& s : samples) total += s.items.size();
    progress.samples_drawn(total);
  }
  Forest forest;
  forest.trees.resize(samples.size());
  tbb::parallel_for(0, static_cast<int>(samples.size()), [&](int t) {
    const auto start = std::chrono::steady_clock::now();
    forest.trees[t] =
        growTree(images, samples[t], forest_params, treeSeed(params.seed, kind, t), progress);
    if (progress.tree_done)
      progress.tree_done(kind, t, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    samples[t].items.clear();
    samples[t].items.shrink_to_fit();
  });
  return forest;
}

}  // namespace relocalizer

namespace relocalizer {

bool appendTrainingImage(const RgbdFrame& frame, std::vector<TrainingImage>& images) {
  if (!frame.ground_truth) return false;
  TrainingImage image;
  image.colour = frame.colour;
  image.depth = frame.depth;
  image.camera = frame.camera;
  image.pose = *frame.ground_truth;
  images.push_back(std::move(image));
  return true;
}

void trainForests(const std::vector<TrainingImage>& images, const TrainingParams& params,
                  Forest& points, Forest& lines, const TrainingProgress& progress) {
  tbb::parallel_invoke(
      [&] {
        if (params.train_points) points = trainForest(images, ForestKind::Points, params, progress);
      },
      [&] {
        if (params.train_lines) lines = trainForest(images, ForestKind::Lines, params, progress);
      });
}

}  // namespace relocalizer
