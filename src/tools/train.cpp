// train: grows the point and line forests on posed RGB-D frames (a dataset
// folder or a rosbag) and writes one model file.

#include <tbb/parallel_for.h>

#include <chrono>
#include <filesystem>
#include <mutex>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "cli_support.h"
#include "relocalizer/core/progress.h"
#include "relocalizer/data/frame_source.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/forest/training_config.h"
#include "source_arguments.h"

using namespace relocalizer;

namespace {

// Frames load in parallel but are kept in dataset order, so the model does
// not depend on the thread count. Frames without a pose are counted, not kept.
Status loadPosedFrames(const FrameSource& data, ModelBuilder& builder, int& without_pose) {
  std::vector<std::optional<RgbdFrame>> frames_read(data.size());
  std::string load_error;
  std::mutex error_mutex;
  {
    ProgressBar bar("loading ", data.size());
    tbb::parallel_for(size_t{0}, data.size(), [&](size_t i) {
      auto frame = data.load(i);
      if (frame) {
        frames_read[i] = std::move(*frame);
      } else {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (load_error.empty()) load_error = frame.error();
      }
      bar.advance();
    });
  }
  if (!load_error.empty()) return makeError(load_error);
  // Each frame is dropped once the builder holds it: under colour
  // normalisation the builder keeps a normalised copy, and keeping every
  // recorded colour image beside it as well cost 227 MB at the peak (300 VGA frames).
  for (auto& frame : frames_read) {
    if (!builder.add(*frame)) ++without_pose;
    frame.reset();
  }
  return okStatus();
}

// Wall times the build reports, for the summary lines.
struct BuildTimes {
  std::mutex mutex;
  std::vector<double> trees[2];  // per forest (points, lines), per tree
  double surface = 0.0;
};

Expected<Model> buildShowingProgress(ModelBuilder& builder, TrainingSummary provenance,
                                     BuildTimes& times) {
  ProgressBar bar("training", 0);
  ModelBuildProgress progress;
  progress.surface_built = [&](double seconds) { times.surface = seconds; };
  progress.forests.samples_drawn = [&](size_t n) { bar.addToTotal(n); };
  progress.forests.samples_done = [&](size_t n) { bar.advance(n); };
  progress.forests.tree_done = [&](ForestKind kind, int tree, double seconds) {
    std::lock_guard<std::mutex> lock(times.mutex);
    auto& forest = times.trees[kind == ForestKind::Lines ? 1 : 0];
    if (static_cast<int>(forest.size()) <= tree) forest.resize(tree + 1);
    forest[tree] = seconds;
  };
  return builder.build(std::move(provenance), progress);
}

void printModel(const Model& model, const BuildTimes& times) {
  for (const auto* f : {&model.points, &model.lines}) {
    if (f->empty()) continue;
    int depth = 0;
    for (const Tree& t : f->trees) depth = std::max(depth, t.depth());
    std::string per_tree;
    for (double t : times.trees[f == &model.points ? 0 : 1])
      per_tree +=
          (per_tree.empty() ? "" : ", ") + std::to_string(static_cast<int>(std::lround(t))) + " s";
    std::printf("  %-6s %zu trees, %zu nodes, %zu leaves, %zu modes, max depth %d; per tree %s\n",
                f == &model.points ? "points" : "lines", f->trees.size(), f->nodeCount(),
                f->leafCount(), f->modeCount(), depth, per_tree.c_str());
  }
  if (model.params.build_surface)
    std::printf("  surface %zu elements of %.0f mm (%.1f MB), fused in %.1f s\n",
                model.surface.elements().size(), 1000.0 * model.surface.voxelSize(),
                model.surface.elements().size() * sizeof(SurfaceElement) / 1e6, times.surface);
  else
    std::printf(
        "  no surface (surface.enabled: false): poses will not be checked against the scene\n");
}

}  // namespace

int main(int argc, char** argv) {
#ifdef __GLIBC__
  // Image-sized blocks (decoding and registration temporaries, the images, the
  // samples) always in their own mappings, returned to the system when freed.
  // glibc otherwise raises this threshold after the first such free, and the
  // loader's freed temporaries stayed resident between the kept images: about
  // 390 MB of the 1 GB peak on the 300 redkitchen frames.
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
#endif
  cli::App app{
      "Trains a PLForests model (point forest + line forest) on the posed RGB-D frames of one "
      "scene and writes it to one versioned binary file. The frames come from a dataset folder "
      "(--dataset) or a rosbag (--bag) whose camera poses are on /tf (e.g. from a SLAM stack) or "
      "on a pose topic. Parameters come from config/forest.yaml (the defaults) and --config.",
      "train"};
  std::string output, config, forests;
  int threads = 0;
  uint64_t seed = 0;
  cli::SourceOptions source_options;
  source_options.add(app, "Dataset folder (7-Scenes, 12-Scenes, TUM)",
                     "Frame ids to train on, e.g. 0-99,200-299 (default: all); for a bag, ids are "
                     "indices in its synchronized frame order");
  app.addOption("-o,--output", output, "Model file to write")->required();
  app.addOption("-c,--config", config, "YAML file overriding config/forest.yaml defaults");
  app.addOption("-j,--threads", threads, "Worker threads (0 = every core)")
      ->range(0, 1024)
      ->showDefault();
  auto* seed_option = app.addOption("--seed", seed, "Random seed (overrides the config)");
  app.addOption("--forests", forests, "Forests to grow: points, lines or points,lines")
      ->oneOf({"points", "lines", "points,lines", "lines,points", "both"});
  if (const cli::Exit done = app.parse(argc, argv)) return *done;

  TrainingParams params;
  if (!config.empty()) {
    auto loaded = loadTrainingParams(config);
    if (!loaded) return cli::fail(app, loaded.error());
    params = *loaded;
  }
  if (*seed_option) params.seed = seed;
  if (!forests.empty()) {
    params.train_points = forests != "lines";
    params.train_lines = forests != "points";
  }
  auto source = source_options.open();
  if (!source) return cli::fail(app, source.error());
  const FrameSource& data = **source;
  const std::string& dataset_path = data.path();
  std::printf("%s\n", data.summary().c_str());

  const int thread_count = cli::resolveThreads(threads);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, thread_count);
  const auto start = std::chrono::steady_clock::now();

  ModelBuilder builder(params);
  int without_pose = 0;
  if (const Status loaded = loadPosedFrames(data, builder, without_pose); !loaded)
    return cli::fail(app, loaded.error());
  if (builder.size() == 0)
    return cli::fail(app, dataset_path + ": no selected frame has a ground-truth pose");
  if (without_pose > 0) std::printf("skipped %d frames without ground truth\n", without_pose);

  TrainingSummary provenance;
  provenance.dataset = dataset_path;
  provenance.format = data.formatDescription();
  // A bag's frames are chosen by poses and key-frame selection too: record the ids used.
  provenance.frames = source_options.bag.empty() ? source_options.frames : data.usedIds();
  provenance.threads = thread_count;
  BuildTimes times;
  const Expected<Model> built = buildShowingProgress(builder, std::move(provenance), times);
  if (!built) return cli::fail(app, built.error());
  const Model& model = *built;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Atomic, as the node's ~save_model: a train killed while writing leaves the old model
  // whole, and a path that holds something other than a model (a folder, a symlink, another
  // file) is refused rather than overwritten.
  if (const Status saved = saveModel(model, output); !saved)
    return cli::fail(app, saved.error(), 1);
  const auto bytes = std::filesystem::file_size(output);

  std::printf("trained on %d images with %d threads in %.1f s (seed %llu)\n", model.summary.images,
              thread_count, seconds, static_cast<unsigned long long>(params.seed));
  printModel(model, times);
  std::printf("wrote %s (%.1f MB)\n", output.c_str(), bytes / 1e6);
  return 0;
}
