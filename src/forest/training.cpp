#include "relocalizer/forest/training.h"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <random>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace relocalizer {

const char* forestKindName(ForestKind kind) {
  return kind == ForestKind::Points ? "points" : "lines";
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

SurfaceModel buildSurface(const std::vector<TrainingImage>& images, const SurfaceParams& params) {
  SurfaceBuilder builder(params);
  for (const TrainingImage& image : images) builder.addFrame(image.depth, image.camera, image.pose);
  return builder.build();
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
