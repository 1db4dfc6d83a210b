#include "relocalizer/online/online_learner.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "relocalizer/core/id_ranges.h"

namespace relocalizer {

std::string learningParamsError(const LearningParams& p) {
  if (p.max_keyframes < 2) return "max_keyframes must be at least 2 (got " + std::to_string(p.max_keyframes) + ")";
  if (p.first_retrain < 1 || p.first_retrain > p.max_keyframes)
    return "first_retrain must be between 1 and max_keyframes (got " + std::to_string(p.first_retrain) + ")";
  if (!(p.retrain_growth >= 0.0 && std::isfinite(p.retrain_growth)))
    return "retrain_growth must be a share >= 0 (got " + std::to_string(p.retrain_growth) + ")";
  if (p.jpeg_quality < 1 || p.jpeg_quality > 100)
    return "jpeg_quality must be 1-100 (got " + std::to_string(p.jpeg_quality) + ")";
  if (p.worker_threads < 1) return "worker_threads must be at least 1";
  if (p.surface_min_frames < 1) return "surface_min_frames must be at least 1";
  if (p.samples_budget_per_tree < 0) return "samples_budget_per_tree must not be negative";
  if (p.min_backtracking_leaves < 1) return "min_backtracking_leaves must be at least 1";
  if (!p.training.train_points && !p.training.train_lines)
    return "training must grow at least one forest (train_points or train_lines)";
  return {};
}

size_t modelBytes(const Model& model) {
  size_t bytes = model.surface.elements().size() * sizeof(SurfaceElement);
  for (const Forest* forest : {&model.points, &model.lines})
    for (const Tree& tree : forest->trees)
      bytes += tree.nodes.size() * sizeof(SplitNode) + tree.modes.size() * sizeof(LeafMode) +
               tree.descriptors.size() * sizeof(Descriptor);
  return bytes;
}

OnlineLearner::OnlineLearner(LearningParams params, RelocalizerParams relocalizer_params, Mode mode)
    : params_(std::move(params)),
      relocalizer_params_([&] {
        RelocalizerParams r = std::move(relocalizer_params);
        if (!params_.surface_gate) r.surface.min_agreement = 0.0f;
        r.max_leaves = std::max(r.max_leaves, params_.min_backtracking_leaves);
        return r;
      }()),
      mode_(mode),
      store_(params_.max_keyframes) {
  if (const std::string why = learningParamsError(params_); !why.empty())
    throw std::invalid_argument("learning parameters: " + why);
  if (mode_ == Mode::Background) worker_ = std::thread([this] { workerLoop(); });
}

OnlineLearner::~OnlineLearner() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  progress_.notify_all();
  if (worker_.joinable()) worker_.join();
}

Status OnlineLearner::resume(Model model, std::vector<StoredKeyFrame> key_frames) {
  if (key_frames.empty()) return makeError("cannot resume learning: the saved place has no key frames");
  auto relocalizer = std::make_shared<Relocalizer>(std::move(model), relocalizer_params_);
  if (const std::string why = relocalizer->validationError(); !why.empty()) return makeError(why);
  std::lock_guard<std::mutex> lock(mutex_);
  if (generation_ != 0) return makeError("resume() must come before the first key frame");
  for (StoredKeyFrame& k : key_frames) {
    if (store_.add(std::make_shared<const StoredKeyFrame>(std::move(k)))) ++status_.keyframes_evicted;
    ++generation_;
  }
  trained_generation_ = model_generation_ = generation_;
  status_.keyframes_added = static_cast<int>(generation_);
  status_.keyframes_learned = static_cast<int>(store_.size());
  status_.model_bytes = modelBytes(relocalizer->model());
  current_ = std::move(relocalizer);
  return okStatus();
}

Status OnlineLearner::resume(const std::string& model_path) {
  auto model = loadModel(model_path);
  if (!model) return makeError(model.error());
  auto key_frames = loadKeyFrames(keyFramesPath(model_path));
  if (!key_frames)
    return makeError("cannot continue learning " + model_path + " without its key frames: " +
                     key_frames.error() + " (a model saved by ~save_model or evaluate --save-model has them)");
  return resume(std::move(*model), std::move(*key_frames));
}

Status OnlineLearner::addKeyFrame(const RgbdFrame& frame, const Pose& camera_to_world) {
  auto compressed = compressKeyFrame(frame, camera_to_world, params_.jpeg_quality);
  if (!compressed) return makeError(compressed.error());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (store_.add(std::make_shared<const StoredKeyFrame>(std::move(*compressed)))) ++status_.keyframes_evicted;
    ++generation_;
    status_.keyframes_added = static_cast<int>(generation_);
  }
  wake_.notify_all();
  return okStatus();
}

bool OnlineLearner::retrainDue() const {
  const long long fresh = generation_ - trained_generation_;
  if (fresh <= 0 || store_.size() == 0) return false;
  if (drain_requested_) return true;
  if (!current_) return static_cast<int>(store_.size()) >= params_.first_retrain;
  const double known = static_cast<double>(status_.keyframes_learned);
  return fresh >= std::max(1LL, static_cast<long long>(std::ceil(params_.retrain_growth * known)));
}

Status OnlineLearner::retrain(std::unique_lock<std::mutex>& lock) {
  // The retrain works on a snapshot: key frames added meanwhile wait for the next.
  const std::vector<KeyFrameStore::Entry> entries = store_.entries();
  const long long snapshot_generation = generation_;
  trained_generation_ = generation_;
  status_.retraining = true;
  lock.unlock();

  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<const Relocalizer> fresh;
  std::string error;
  try {
    std::vector<TrainingImage> images;
    images.reserve(entries.size());
    for (const auto& entry : entries) {
      auto image = decompressKeyFrame(*entry);
      if (!image) throw std::runtime_error(image.error());
      images.push_back(std::move(*image));
    }
    Model model;
    model.params = params_.training;
    model.params.surface.min_frames = params_.surface_min_frames;
    if (params_.samples_budget_per_tree > 0)
      for (ForestParams* forest : {&model.params.points, &model.params.lines})
        forest->samples_per_image = std::clamp(
            params_.samples_budget_per_tree / static_cast<int>(images.size()),
            std::min(1000, forest->samples_per_image), forest->samples_per_image);
    // Shutdown must not wait for a retrain of a full store (a minute): the
    // progress callback, called as samples reach leaves, aborts it.
    TrainingProgress progress;
    progress.samples_done = [this](size_t) {
      if (stop_) throw std::runtime_error("stopped");
    };
    trainForests(images, model.params, model.points, model.lines, progress);
    if (model.params.build_surface) model.surface = buildSurface(images, model.params.surface);
    TrainingSummary& summary = model.summary;
    summary.dataset = "online";
    summary.format = "key frames learned online";
    std::vector<int> ids;
    for (const auto& entry : entries) ids.push_back(entry->id);
    summary.frames = formatIdRanges(ids);
    summarizeTrainingImages(images, summary);
    summary.threads = mode_ == Mode::Background ? params_.worker_threads : 0;
    summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    auto relocalizer = std::make_shared<Relocalizer>(std::move(model), relocalizer_params_);
    if (const std::string why = relocalizer->validationError(); !why.empty()) throw std::runtime_error(why);
    fresh = std::move(relocalizer);
  } catch (const std::exception& e) {
    error = std::string("retrain on ") + std::to_string(entries.size()) + " key frames failed: " + e.what();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  lock.lock();
  status_.retraining = false;
  if (!fresh) {
    status_.last_error = error;
    progress_.notify_all();
    return makeError(error);
  }
  status_.model_bytes = modelBytes(fresh->model());
  status_.keyframes_learned = static_cast<int>(entries.size());
  status_.last_retrain_seconds = seconds;
  ++status_.retrains;
  model_generation_ = snapshot_generation;
  current_ = std::move(fresh);  // the old model lives on in the callers that hold it
  progress_.notify_all();
  return okStatus();
}

void OnlineLearner::workerLoop() {
  // Training must not take the CPU from relocalization and SLAM: a nicer
  // thread (Linux nice is per thread) and an arena of worker_threads, so TBB
  // does not spread the retrain onto the callers' threads.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), params_.worker_nice);
  tbb::task_arena arena(params_.worker_threads, 1);
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [&] { return stop_ || retrainDue(); });
    if (stop_) return;
    arena.execute([&] { (void)retrain(lock); });  // a failure is in status().last_error
  }
}

Status OnlineLearner::drain() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (mode_ == Mode::Inline) {
    if (generation_ == model_generation_ || store_.size() == 0) return okStatus();
    return retrain(lock);
  }
  const std::string error_before = status_.last_error;
  drain_requested_ = true;
  wake_.notify_all();
  progress_.wait(lock, [&] {
    return stop_ || status_.last_error != error_before ||
           (!status_.retraining && (generation_ == model_generation_ || store_.size() == 0));
  });
  drain_requested_ = false;
  if (status_.last_error != error_before) return makeError(status_.last_error);
  return okStatus();
}

std::shared_ptr<const Relocalizer> OnlineLearner::current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return current_;
}

LearningStatus OnlineLearner::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LearningStatus s = status_;
  s.keyframes_stored = static_cast<int>(store_.size());
  s.store_bytes = store_.bytes();
  s.backlog = static_cast<int>(generation_ - model_generation_);
  return s;
}

Status OnlineLearner::save(const std::string& path) const {
  std::shared_ptr<const Relocalizer> model;
  std::vector<KeyFrameStore::Entry> entries;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    model = current_;
    entries = store_.entries();
  }
  if (!model) return makeError(path + ": nothing to save yet: no model has been learned (too few key frames)");
  // Key frames first: they are the place; a model older than them is only
  // retrained sooner when the place is continued.
  if (Status saved = saveKeyFrames(entries, keyFramesPath(path)); !saved) return saved;
  return writeFileAtomically(path, serializeModel(model->model()));
}

}  // namespace relocalizer
