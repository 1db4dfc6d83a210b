#include "relocalizer/forest/training.h"

#include <sys/mman.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <numeric>
#include <random>

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

TreeSamples::Item makeItem(int image, const Sample& s, const TrainingImage& source) {
  TreeSamples::Item item;
  item.image = image;
  const cv::Vec3b& colour = source.colour.at<cv::Vec3b>(s.v, s.u);
  item.colour = {colour[0], colour[1], colour[2]};
  item.u = s.u;
  item.v = s.v;
  item.depth = s.depth;
  item.world = (source.pose.cast<float>() * s.camera_point);
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

namespace {

// One tree's share of the sampling: its random stream and chosen images.
struct TreeDraw {
  ForestKind kind;
  int tree;
  const ForestParams* params;
  std::mt19937 rng;
  std::vector<int> chosen;  // ascending
  size_t next = 0;          // first chosen image not drawn yet
  TreeSamples samples;
};

// The line samples of every image (LSD once per image; trees subsample them).
std::vector<LineSamples> lineSamplesPerImage(const std::vector<TrainingImage>& images,
                                             const TrainingParams& params) {
  std::vector<LineSamples> cache(images.size());
  tbb::parallel_for(0, static_cast<int>(images.size()), [&](int i) {
    std::mt19937 rng(static_cast<uint32_t>(treeSeed(params.seed, ForestKind::Lines, 100000 + i)));
    cache[i] = sampleLines(asFrame(images[i]), params.line_sampling, 0, rng);
  });
  return cache;
}

void drawFromImage(TreeDraw& draw, const std::vector<TrainingImage>& images, int i,
                   const std::vector<LineSamples>& line_cache, std::vector<Sample>& drawn) {
  drawn.clear();
  if (draw.kind == ForestKind::Points) {
    samplePoints(asFrame(images[i]), draw.params->samples_per_image, draw.rng, drawn);
  } else {
    const auto& all = line_cache[i].samples;
    const int take = std::min<int>(draw.params->samples_per_image, static_cast<int>(all.size()));
    std::vector<int> order(all.size());
    std::iota(order.begin(), order.end(), 0);
    for (int k = 0; k < take; ++k) {
      std::uniform_int_distribution<int> pick(k, static_cast<int>(order.size()) - 1);
      std::swap(order[k], order[pick(draw.rng)]);
      drawn.push_back(all[order[k]]);
    }
  }
  for (const Sample& s : drawn) draw.samples.items.push_back(makeItem(i, s, images[i]));
}

// Every tree's samples for the forests in `kinds`. Each tree draws from its
// chosen images in increasing order with its own random stream. Going image by
// image, with every tree that chose the image drawing from it, keeps each
// stream in that order, so the samples are the same as drawing tree by tree;
// and once an image is passed no tree needs its depth again, which
// `image_done` may use to free it.
std::vector<TreeDraw> drawSamples(const std::vector<TrainingImage>& images,
                                  const TrainingParams& params,
                                  const std::vector<ForestKind>& kinds,
                                  const std::function<void(int)>& image_done) {
  const int n_images = static_cast<int>(images.size());
  std::vector<TreeDraw> draws;
  std::vector<LineSamples> line_cache;
  for (ForestKind kind : kinds) {
    const ForestParams& forest = kind == ForestKind::Points ? params.points : params.lines;
    if (kind == ForestKind::Lines) line_cache = lineSamplesPerImage(images, params);
    for (int t = 0; t < forest.trees; ++t) {
      TreeDraw draw{
          kind, t, &forest, std::mt19937(static_cast<uint32_t>(treeSeed(params.seed, kind, t))),
          {},   0, {}};
      draw.chosen = chooseImages(n_images, forest.images_per_tree, draw.rng);
      // Reserved to size (points: at most samples_per_image an image; lines:
      // what each image has), so the largest allocation of training grows
      // without push_back's doubling slack.
      size_t expected = 0;
      for (int i : draw.chosen)
        expected += kind == ForestKind::Points
                        ? static_cast<size_t>(std::max(0, forest.samples_per_image))
                        : std::min<size_t>(std::max(0, forest.samples_per_image),
                                           line_cache[i].samples.size());
      draw.samples.items.reserve(expected);
      draws.push_back(std::move(draw));
    }
  }
  for (int i = 0; i < n_images; ++i) {
    tbb::parallel_for(size_t{0}, draws.size(), [&](size_t d) {
      TreeDraw& draw = draws[d];
      if (draw.next >= draw.chosen.size() || draw.chosen[draw.next] != i) return;
      ++draw.next;
      thread_local std::vector<Sample> drawn;
      drawFromImage(draw, images, i, line_cache, drawn);
    });
    if (image_done) image_done(i);
  }
  return draws;
}

// Grows every drawn tree, in parallel, largest sample set first: trees take a
// time roughly proportional to their samples, and starting the largest first
// keeps the last thread from finishing alone on a big tree. A shared counter
// rather than a partitioned range, which would give each thread a fixed half.
void growTrees(const std::vector<TrainingImage>& images, std::vector<TreeDraw>& draws,
               const TrainingProgress& progress, const TrainingParams& params,
               std::vector<Forest*> forests) {
  std::vector<size_t> order(draws.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return draws[a].samples.items.size() > draws[b].samples.items.size();
  });
  for (const TreeDraw& draw : draws) {
    Forest& forest = *forests[static_cast<int>(draw.kind)];
    forest.trees.resize(std::max<size_t>(forest.trees.size(), draw.tree + 1));
  }
  std::atomic<size_t> next{0};
  const int workers = std::max(1, tbb::this_task_arena::max_concurrency());
  tbb::parallel_for(
      0, workers,
      [&](int) {
        for (size_t k = next++; k < order.size(); k = next++) {
          TreeDraw& draw = draws[order[k]];
          const auto start = std::chrono::steady_clock::now();
          forests[static_cast<int>(draw.kind)]->trees[draw.tree] =
              growTree(images, draw.samples, *draw.params, params.descriptor_normalisation,
                       treeSeed(params.seed, draw.kind, draw.tree), progress);
          if (progress.tree_done)
            progress.tree_done(
                draw.kind, draw.tree,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
          draw.samples.items.clear();
          draw.samples.items.shrink_to_fit();
        }
      },
      tbb::simple_partitioner());
}

void reportDrawn(const std::vector<TreeDraw>& draws, const TrainingProgress& progress) {
  if (!progress.samples_drawn) return;
  for (ForestKind kind : {ForestKind::Points, ForestKind::Lines}) {
    size_t total = 0;
    bool any = false;
    for (const TreeDraw& draw : draws)
      if (draw.kind == kind) {
        total += draw.samples.items.size();
        any = true;
      }
    if (any) progress.samples_drawn(total);
  }
}

std::vector<ForestKind> enabledForests(const TrainingParams& params) {
  std::vector<ForestKind> kinds;
  if (params.train_points) kinds.push_back(ForestKind::Points);
  if (params.train_lines) kinds.push_back(ForestKind::Lines);
  return kinds;
}

void trainForestsImpl(const std::vector<TrainingImage>& images, const TrainingParams& params,
                      Forest& points, Forest& lines, const TrainingProgress& progress,
                      const std::function<void(int)>& image_done) {
  std::vector<TreeDraw> draws = drawSamples(images, params, enabledForests(params), image_done);
  reportDrawn(draws, progress);
  if (params.train_points) points = Forest{};
  if (params.train_lines) lines = Forest{};
  growTrees(images, draws, progress, params, {&points, &lines});
}

}  // namespace

std::vector<TreeSamples> drawTreeSamples(const std::vector<TrainingImage>& images, ForestKind kind,
                                         const TrainingParams& params) {
  std::vector<TreeDraw> draws = drawSamples(images, params, {kind}, {});
  std::vector<TreeSamples> samples;
  for (TreeDraw& draw : draws) samples.push_back(std::move(draw.samples));
  return samples;
}

Forest trainForest(const std::vector<TrainingImage>& images, ForestKind kind,
                   const TrainingParams& params, const TrainingProgress& progress) {
  std::vector<TreeDraw> draws = drawSamples(images, params, {kind}, {});
  reportDrawn(draws, progress);
  Forest points, lines;
  growTrees(images, draws, progress, params, {&points, &lines});
  return kind == ForestKind::Points ? points : lines;
}

}  // namespace relocalizer

namespace relocalizer {

bool appendTrainingImage(const RgbdFrame& frame, const TrainingParams& params,
                         std::vector<TrainingImage>& images) {
  if (!frame.ground_truth) return false;
  TrainingImage image;
  image.colour = frame.colour;
  image.depth = frame.depth;
  image.camera = frame.camera;
  image.pose = *frame.ground_truth;
  appendTrainingImage(std::move(image), params, images);
  return true;
}

void appendTrainingImage(TrainingImage image, const TrainingParams& params,
                         std::vector<TrainingImage>& images) {
  if (params.light_augmentation.enabled()) {
    // Its own stream per image, apart from the trees' and the line cache's.
    constexpr int kLightStreams = 200000;
    const uint64_t bits =
        treeSeed(params.seed, ForestKind::Points, kLightStreams + static_cast<int>(images.size()));
    image.colour = applyPhotometricChange(image.colour, drawLight(params.light_augmentation, bits));
  }
  image.colour = normaliseColour(image.colour, params.colour_normalisation);
  images.push_back(std::move(image));
}

SurfaceModel buildSurface(const std::vector<TrainingImage>& images, const SurfaceParams& params) {
  SurfaceBuilder builder(params);
  for (const TrainingImage& image : images) builder.addFrame(image.depth, image.camera, image.pose);
  return builder.build();
}

namespace {

// Moves every image's colour into one block whose 2 MB-aligned interior the
// kernel may back with huge pages: the split search reads training colour at
// random over hundreds of images, and on 4 kB pages nearly every read also
// misses the TLB. The images keep the same pixels (each a view into the
// block, which lives as long as any of them).
void packColourOnHugePages(std::vector<TrainingImage>& images) {
  constexpr size_t kHugePage = size_t{2} << 20;
  constexpr size_t kAlign = 64;
  size_t total = 0;
  for (const TrainingImage& image : images)
    total += (image.colour.total() * image.colour.elemSize() + kAlign - 1) / kAlign * kAlign;
  // One cv::Mat row holds the block: more than INT_MAX bytes (some 2300 VGA
  // images) stay where they are.
  if (total < kHugePage || total + kHugePage > static_cast<size_t>(INT_MAX)) return;
  cv::Mat block(1, static_cast<int>(total + kHugePage), CV_8UC1);
  const uintptr_t start = reinterpret_cast<uintptr_t>(block.data);
  const uintptr_t aligned = (start + kHugePage - 1) / kHugePage * kHugePage;
#ifdef MADV_HUGEPAGE
  madvise(reinterpret_cast<void*>(aligned), total / kHugePage * kHugePage, MADV_HUGEPAGE);
#endif
  size_t offset = aligned - start;
  for (TrainingImage& image : images) {
    if (image.colour.empty()) continue;
    const size_t bytes = image.colour.total() * image.colour.elemSize();
    cv::Mat packed = block.colRange(static_cast<int>(offset), static_cast<int>(offset + bytes))
                         .reshape(image.colour.channels(), image.colour.rows);
    image.colour.copyTo(packed);
    image.colour = packed;
    offset += (bytes + kAlign - 1) / kAlign * kAlign;
  }
}

}  // namespace

void trainForestsReleasingDepth(std::vector<TrainingImage>& images, const TrainingParams& params,
                                Forest& points, Forest& lines, const TrainingProgress& progress) {
  packColourOnHugePages(images);
  const bool depth_features = (params.train_points && params.points.depth_feature_share > 0.0f) ||
                              (params.train_lines && params.lines.depth_feature_share > 0.0f);
  std::function<void(int)> release;
  if (!depth_features) release = [&images](int i) { images[i].depth.release(); };
  trainForestsImpl(images, params, points, lines, progress, release);
}
}  // namespace relocalizer
