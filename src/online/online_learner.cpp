#include "relocalizer/online/online_learner.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "relocalizer/core/file_io.h"
#include "relocalizer/core/id_ranges.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/forest/training_config.h"

namespace relocalizer {
namespace {

std::vector<KeyFrameStore::Entry> shareKeyFrames(std::vector<StoredKeyFrame> key_frames) {
  std::vector<KeyFrameStore::Entry> shared;
  shared.reserve(key_frames.size());
  for (StoredKeyFrame& k : key_frames)
    shared.push_back(std::make_shared<const StoredKeyFrame>(std::move(k)));
  return shared;
}

}  // namespace

std::string learningParamsError(const LearningParams& p, const SettingName& name) {
  const auto n = [&](const std::string& field) { return settingName(name, field); };
  if (!(p.min_motion.metres >= 0.0 && std::isfinite(p.min_motion.metres) &&
        p.min_motion.degrees >= 0.0 && std::isfinite(p.min_motion.degrees)))
    return n("min_motion") + " must be finite and >= 0 (got " + formatMinMotion(p.min_motion) + ")";
  if (p.max_keyframes < 2)
    return n("max_keyframes") + " must be at least 2 (got " + std::to_string(p.max_keyframes) + ")";
  if (p.first_retrain < 1 || p.first_retrain > p.max_keyframes)
    return n("first_retrain") + " must be between 1 and " + n("max_keyframes") + " (got " +
           std::to_string(p.first_retrain) + ")";
  if (!(p.retrain_growth >= 0.0 && std::isfinite(p.retrain_growth)))
    return n("retrain_growth") + " must be a finite share >= 0 (got " +
           std::to_string(p.retrain_growth) + ")";
  if (p.jpeg_quality < 1 || p.jpeg_quality > 100)
    return n("jpeg_quality") + " must be 1-100 (got " + std::to_string(p.jpeg_quality) + ")";
  if (p.worker_threads < 1) return n("worker_threads") + " must be at least 1";
  if (p.surface_min_frames < 1) return n("surface_min_frames") + " must be at least 1";
  if (p.samples_budget_per_tree < 0) return n("samples_budget_per_tree") + " must not be negative";
  if (p.min_backtracking_leaves < 1) return n("min_backtracking_leaves") + " must be at least 1";
  if (std::string why = slamCheckParamsError(p.slam_check, name); !why.empty()) return why;
  if (!p.training.train_points && !p.training.train_lines)
    return n("config") + " must grow at least one forest (train_points or train_lines)";
  return {};
}

Expected<LearningParams> readLearningParams(LearningParams params, const std::string& min_motion,
                                            const std::string& training_config,
                                            const SettingName& name) {
  const auto n = [&](const std::string& field) { return settingName(name, field); };
  auto motion = parseMinMotion(min_motion);
  if (!motion) return makeError(n("min_motion") + ": " + motion.error());
  params.min_motion = *motion;
  if (!training_config.empty()) {
    auto training = loadTrainingParams(training_config);
    if (!training) return makeError(n("config") + ": " + training.error());
    params.training = *training;
  }
  if (const std::string why = learningParamsError(params, name); !why.empty())
    return makeError(why);
  return params;
}

RelocalizerParams learnedModelParams(const LearningParams& learning, RelocalizerParams params) {
  if (!learning.surface_gate) {
    params.surface.min_agreement = 0.0f;
    params.surface.min_on_surface = 0.0f;
    params.surface.max_seen_through = 1.0f;
  }
  params.max_leaves = std::max(params.max_leaves, learning.min_backtracking_leaves);
  return params;
}

OnlineLearner::OnlineLearner(LearningParams params, RelocalizerParams relocalizer_params, Mode mode,
                             LearnerNames names)
    : params_(std::move(params)),
      relocalizer_params_(learnedModelParams(params_, std::move(relocalizer_params))),
      mode_(mode),
      names_(std::move(names)),
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
  if (key_frames.empty())
    return makeError("cannot resume learning: the saved place has no key frames");
  auto relocalizer = std::make_shared<Relocalizer>(std::move(model), relocalizer_params_);
  if (const std::string why = relocalizer->validationError(); !why.empty()) return makeError(why);
  return adoptKeyFrames(shareKeyFrames(std::move(key_frames)), std::move(relocalizer), {});
}

Status OnlineLearner::seed(std::vector<KeyFrameStore::Entry> key_frames) {
  return adoptKeyFrames(std::move(key_frames), nullptr, {});
}

std::vector<KeyFrameStore::Entry> OnlineLearner::keyFrames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return store_.entries();
}

Status OnlineLearner::adoptKeyFrames(std::vector<KeyFrameStore::Entry> key_frames,
                                     std::shared_ptr<const Relocalizer> model, std::string note) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (generation_ != 0)
    return makeError("resume() and seed() must come before the first key frame");
  for (KeyFrameStore::Entry& k : key_frames) {
    if (store_.add(std::move(k))) ++status_.keyframes_evicted;
    ++generation_;
  }
  status_.keyframes_added = static_cast<int>(generation_);
  status_.last_error = std::move(note);
  if (!model) return okStatus();  // nothing learned yet: the first retrain is due
  trained_generation_ = model_generation_ = generation_;
  status_.keyframes_learned = static_cast<int>(store_.size());
  status_.model_bytes = modelBytes(model->model());
  current_ = std::move(model);
  return okStatus();
}

Status OnlineLearner::resume(const std::string& model_path) {
  auto model_file = readRegularFile(model_path, modelFileFormat("model file"));
  if (!model_file) return makeError(model_file.error());
  auto model = deserializeModel(model_file->data(), model_file->size(), model_path);
  if (!model) return makeError(model.error());
  const std::string key_frames_path = keyFramesPath(model_path);
  auto saved = loadKeyFrames(key_frames_path);
  if (!saved)
    return makeError("cannot continue learning " + model_path +
                     " without its key frames: " + saved.error() +
                     " (a model saved by ~save_model or evaluate --save-model has them)");
  // Version-1 key frames carry no identity and resume as they always did.
  if (!saved->savedWith(modelFileId(*model_file))) {
    // Retrain rather than refuse: the key frames are the place and the model
    // is derived from them, so they lose nothing; the model beside them is
    // from an older save and would answer as if it knew frames it never saw.
    // Refusing would leave the user only the choice of starting over.
    if (saved->key_frames.empty())
      return makeError(key_frames_path + ": the saved place has no key frames");
    const size_t count = saved->key_frames.size();
    return adoptKeyFrames(
        shareKeyFrames(std::move(saved->key_frames)), nullptr,
        key_frames_path + " was saved with another model than " + model_path +
            " (a save was interrupted between the two files): not using that model, "
            "retraining on the " +
            std::to_string(count) + " key frames");
  }
  return resume(std::move(*model), std::move(saved->key_frames));
}

Expected<KeyFrameAdded> OnlineLearner::addKeyFrame(const RgbdFrame& frame,
                                                   const Pose& camera_to_world) {
  auto compressed = compressKeyFrame(frame, camera_to_world, params_.jpeg_quality);
  if (!compressed) return makeError(compressed.error());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (store_.add(std::make_shared<const StoredKeyFrame>(std::move(*compressed))))
      ++status_.keyframes_evicted;
    ++generation_;
    status_.keyframes_added = static_cast<int>(generation_);
  }
  wake_.notify_all();
  return KeyFrameAdded::Stored;
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
  RetrainStages stages;
  auto stage_start = start;
  const auto stage_done = [&stage_start](double& stage) {
    const auto now = std::chrono::steady_clock::now();
    stage += std::chrono::duration<double>(now - stage_start).count();
    stage_start = now;
  };
  std::shared_ptr<const Relocalizer> fresh;
  std::string error;
  try {
    TrainingParams training = params_.training;
    training.surface.min_frames = params_.surface_min_frames;
    if (params_.samples_budget_per_tree > 0)
      for (ForestParams* forest : {&training.points, &training.lines})
        forest->samples_per_image =
            std::clamp(params_.samples_budget_per_tree / static_cast<int>(entries.size()),
                       std::min(1000, forest->samples_per_image), forest->samples_per_image);
    // Decoding ran alone before the training's parallel stages (0.6-0.9 s of
    // a 64-key-frame retrain measured at load): in parallel, each key frame on
    // its own, then added in store order, on which the model depends.
    std::vector<Expected<TrainingImage>> images(entries.size(), makeError("key frame not decoded"));
    tbb::parallel_for(size_t{0}, entries.size(),
                      [&](size_t i) { images[i] = decompressKeyFrame(*entries[i]); });
    ModelBuilder builder(training);
    for (auto& image : images) {
      if (!image) throw std::runtime_error(image.error());
      builder.add(std::move(*image));
    }
    images.clear();
    stage_done(stages.decode);
    TrainingSummary provenance;
    provenance.dataset = "online";
    provenance.format = "key frames learned online";
    std::vector<int> ids;
    for (const auto& entry : entries) ids.push_back(entry->id);
    provenance.frames = formatIdRanges(ids);
    provenance.threads = mode_ == Mode::Background ? params_.worker_threads : 0;
    // Shutdown must not wait for a retrain of a full store (a minute): the
    // progress callback, called as samples reach leaves, aborts it.
    ModelBuildProgress progress;
    progress.forests.samples_done = [this](size_t) {
      if (stop_) throw std::runtime_error("stopped");
    };
    progress.surface_built = [&](double) { stage_done(stages.surface); };
    // Called once per forest, both after all drawing: the second adds nothing.
    progress.forests.samples_drawn = [&](size_t) { stage_done(stages.sampling); };
    auto model = builder.build(std::move(provenance), progress);
    if (!model) throw std::runtime_error(model.error());
    stage_done(stages.growing);
    auto relocalizer = std::make_shared<Relocalizer>(std::move(*model), relocalizer_params_);
    if (const std::string why = relocalizer->validationError(); !why.empty())
      throw std::runtime_error(why);
    fresh = std::move(relocalizer);
    stage_done(stages.serving);
  } catch (const std::exception& e) {
    error = std::string("retrain on ") + std::to_string(entries.size()) +
            " key frames failed: " + e.what();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

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
  status_.last_retrain_stages = stages;
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

std::vector<Place> OnlineLearner::places() const {
  std::shared_ptr<const Relocalizer> model = current();
  if (!model) return {};
  return {{names_.place, names_.map_frame, "", std::move(model), names_.place, ""}};
}

LearnerSummary OnlineLearner::summary() const {
  const LearningStatus s = status();
  return {s.keyframes_added, s.keyframes_learned, s.backlog, s.last_error};
}

LearningStatus OnlineLearner::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LearningStatus s = status_;
  s.keyframes_stored = static_cast<int>(store_.size());
  s.store_bytes = store_.bytes();
  s.backlog = static_cast<int>(generation_ - model_generation_);
  return s;
}

Status OnlineLearner::save(const std::string& path) {
  std::shared_ptr<const Relocalizer> model;
  std::vector<KeyFrameStore::Entry> entries;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    model = current_;
    entries = store_.entries();
  }
  if (!model)
    return makeError(path +
                     ": nothing to save yet: no model has been learned (too few key frames)");
  std::vector<uint8_t> model_file = serializeModel(model->model());
  const ModelFileId model_id = modelFileId(model_file);
  // Key frames first: renamed before the model they name, a save interrupted
  // in between leaves key frames that resume() sees belong to another model.
  std::vector<FileReplacement> files;
  files.push_back(
      keyFrameFileReplacement(keyFramesPath(path), serializeKeyFrames(entries, model_id)));
  files.push_back(modelFileReplacement(path, std::move(model_file)));
  return replaceFiles(files);
}

}  // namespace relocalizer
