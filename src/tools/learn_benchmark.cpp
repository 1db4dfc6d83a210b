// learn_benchmark: online learning against the clock. Streams the learn frames
// of a dataset at a camera's rate (looping them for as long as asked), as the
// node receives them beside SLAM: key frames go to the background learner,
// while a second thread relocalizes held-out frames at the node's continuous
// rate on whatever model is current. Reports whether the stream kept up, when
// the first correct relocalization came, relocalization latency and memory.
// With --submaps the stream is learned as submaps (online/submap_learner.h),
// as the node does, and each frame is relocalized across all of them. With
// --model the learner continues a saved place, as the node in learn mode with
// `model` does: how a changed place heals against the clock.

#include <array>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "cli_support.h"
#include "dataset_arguments.h"
#include "learn_options.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/latency_benchmark.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/learner.h"
#include "relocalizer/online/submap_learner.h"

using namespace relocalizer;
using Clock = std::chrono::steady_clock;

namespace {

// Resident and peak resident memory of this process, MiB.
std::pair<double, double> residentMiB() {
  const ResidentMemory memory = residentMemory();
  return {memory.current / 1048576.0, memory.peak / 1048576.0};
}

double since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Attempt {
  double at, latency;
  bool correct;
  bool wrong;  // answered beyond kWrongPose (metrics.h)
  int keyframes_learned;
  int frame;  // its id, so that latency can be read per place
};

// What is learned so far, as the relocalizing thread sees it: the learner's
// places (one store's model, or every submap's) as one group.
class Learned {
 public:
  explicit Learned(const Learner& learner) : learner_(learner) {}

  // False while nothing is learned yet. The places are put again only when a
  // model changed (a retrain or a freeze swapped one in).
  bool ready() {
    std::vector<Place> places = learner_.places();
    std::vector<std::shared_ptr<const Relocalizer>> now;
    for (const Place& place : places) now.push_back(place.relocalizer);
    if (now != models_ && !now.empty()) {
      if (!putLearned(std::move(places), places_)) return false;
      models_ = std::move(now);
    }
    return !models_.empty();
  }
  Relocalization relocalize(const RgbdFrame& frame) const {
    return places_.relocalize(frame).relocalization;
  }
  int keyFramesLearned() const { return learner_.summary().keyframes_learned; }

 private:
  const Learner& learner_;
  std::vector<std::shared_ptr<const Relocalizer>> models_;
  PlaceSet places_;
};

// Relocalizes the test frames round-robin at `rate` on whatever is learned,
// until `done`, reading each frame when used.
std::vector<Attempt> relocalizeUntilDone(const Dataset& test_data,
                                         const std::vector<size_t>& test_frames, Learned& learned,
                                         double rate, Clock::time_point start,
                                         const std::atomic<bool>& done) {
  std::vector<Attempt> attempts;
  size_t next = 0;
  const auto period = std::chrono::duration<double>(1.0 / rate);
  Clock::time_point slot = Clock::now();
  while (!done) {
    std::this_thread::sleep_until(slot);
    slot += std::chrono::duration_cast<Clock::duration>(period);
    if (!learned.ready()) continue;
    auto loaded = test_data.load(test_frames[next++ % test_frames.size()]);
    if (!loaded) continue;
    const RgbdFrame& frame = *loaded;
    const auto t0 = Clock::now();
    const Relocalization r = learned.relocalize(frame);
    const EvaluationRecord record = recordAttempt(frame.id, frame.stamp, *frame.ground_truth, r);
    const FrameError error = frameError(record.id, record.estimate, record.truth);
    attempts.push_back({since(start), since(t0), within(error, kCorrectPose), wrongAnswer(error),
                        learned.keyFramesLearned(), frame.id});
    if (slot < Clock::now()) slot = Clock::now();
  }
  return attempts;
}

// What the stream measured.
struct Stream {
  double rate = 0.0, seconds = 0.0, worst_lag = 0.0;
  long frames = 0, late = 0;
  // Every frame's outcome (KeyFrameFeed::Result::Outcome order): they sum to `frames`.
  std::array<long, 6> outcomes{};
  std::vector<std::array<double, 6>> timeline;  // t, frames, key frames, learned, backlog, RSS
};

// The stream: frame k (of `learn_frames`, looped) is due at k / rate and
// offered; loading it stands for the camera driver and the message
// conversion. `sample` gives the key frames added, learned and the backlog,
// every 5 s whatever the frames' outcome: a looped stream learns little, and
// memory must be seen then too. Returns why a frame failed, or empty.
std::string streamFrames(size_t learn_frames, double seconds, Clock::time_point start,
                         const std::function<KeyFrameFeed::Result(size_t)>& offer,
                         const std::function<std::array<double, 3>()>& sample, Stream& stream) {
  long& frames = stream.frames;
  double next_sample = 0.0;
  std::string failure;
  for (; since(start) < seconds; ++frames) {
    const Clock::time_point due = start + std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(frames / stream.rate));
    std::this_thread::sleep_until(due);
    const double lag = std::chrono::duration<double>(Clock::now() - due).count();
    stream.worst_lag = std::max(stream.worst_lag, lag);
    if (lag > 1.0 / stream.rate) ++stream.late;
    const KeyFrameFeed::Result fed = offer(static_cast<size_t>(frames) % learn_frames);
    ++stream.outcomes[static_cast<size_t>(fed.outcome)];
    if (!fed.why.empty() && fed.outcome != KeyFrameFeed::Result::Outcome::Refused) {
      failure = fed.why;
      ++frames;
      break;
    }
    if (since(start) >= next_sample) {
      const std::array<double, 3> learned = sample();
      stream.timeline.push_back({since(start), static_cast<double>(frames), learned[0], learned[1],
                                 learned[2], residentMiB().first});
      next_sample = since(start) + 5.0;
    }
  }
  stream.seconds = since(start);
  return failure;
}

// What the relocalizing thread's attempts add up to.
struct AttemptTally {
  double first_correct = -1.0;  // stream seconds; -1: none
  int correct = 0, wrong = 0;
  double p50 = 0.0, p95 = 0.0;  // latency, ms
  // Attempts, correct and wrong ones in each kWindowSeconds of the stream:
  // how a place that is learned (or heals) gets better with time.
  static constexpr double kWindowSeconds = 10.0;
  std::vector<std::array<int, 3>> windows;
};

AttemptTally tally(const std::vector<Attempt>& attempts) {
  AttemptTally t;
  std::vector<double> latencies;
  for (const Attempt& a : attempts) {
    if (a.correct && t.first_correct < 0) t.first_correct = a.at;
    t.correct += a.correct;
    t.wrong += a.wrong;
    latencies.push_back(1000.0 * a.latency);
    const auto window = static_cast<size_t>(a.at / AttemptTally::kWindowSeconds);
    if (t.windows.size() <= window) t.windows.resize(window + 1, {0, 0, 0});
    ++t.windows[window][0];
    t.windows[window][1] += a.correct;
    t.windows[window][2] += a.wrong;
  }
  t.p50 = latencies.empty() ? 0.0 : median(latencies);
  t.p95 = latencies.empty() ? 0.0 : percentile(latencies, 95.0);
  return t;
}

// `status` is the one learner's, or with submaps the active submap's (`submaps` then set).
void report(const Stream& stream, const std::vector<Attempt>& attempts,
            const LearningStatus& status, const SubmapStatus* submaps, const std::string& output) {
  const auto [rss, peak] = residentMiB();
  const AttemptTally t = tally(attempts);
  std::printf(
      "stream: %ld frames in %.1f s at %.0f Hz (%ld later than one frame period, worst lag %.0f "
      "ms)\n",
      stream.frames, stream.seconds, stream.rate, stream.late, 1000.0 * stream.worst_lag);
  std::printf(
      "learning%s: %d key frames added, %d stored, %d evicted; %d retrains, the last %.1f s; "
      "backlog "
      "%d; "
      "model %.1f MB, key frames %.1f MB\n",
      submaps ? " (the active submap)" : "", status.keyframes_added, status.keyframes_stored,
      status.keyframes_evicted, status.retrains, status.last_retrain_seconds, status.backlog,
      status.model_bytes / 1e6, status.store_bytes / 1e6);
  std::printf(
      "frames: %ld untracked, %ld not key frames, %ld key frames learned, %ld covered, %ld "
      "failed, %ld refused (SLAM pose check)\n",
      stream.outcomes[0], stream.outcomes[1], stream.outcomes[2], stream.outcomes[3],
      stream.outcomes[4], stream.outcomes[5]);
  if (submaps)
    std::printf(
        "submaps: %d, key frames per submap (seeds included) %s; %d key frames covered by frozen "
        "submaps; all models %.1f MB; freezes: at most %d pending at once (%d still), %d new "
        "submaps waited %.1f s for room%s%s\n",
        submaps->submaps, nlohmann::json(submaps->submap_keyframes).dump().c_str(),
        submaps->keyframes_covered, submaps->model_bytes / 1e6, submaps->freezes_pending_most,
        submaps->freezes_pending, submaps->freeze_waits, submaps->freeze_wait_seconds,
        submaps->last_error.empty() ? "" : "; last error: ", submaps->last_error.c_str());
  std::printf(
      "relocalization: %zu attempts, %d correct (5 cm / 5 deg), %d wrong (> 10 cm / 10 deg); first "
      "correct at %.1f s of stream; latency median %.0f ms, p95 %.0f ms\n",
      attempts.size(), t.correct, t.wrong, t.first_correct, t.p50, t.p95);
  std::string by_window;
  for (size_t w = 0; w < t.windows.size(); ++w)
    by_window += (w ? ", " : "") + std::to_string(t.windows[w][1]) + "/" +
                 std::to_string(t.windows[w][0]) +
                 (t.windows[w][2] ? " (" + std::to_string(t.windows[w][2]) + " wrong)" : "");
  if (!t.windows.empty())
    std::printf("correct per %.0f s of stream: %s\n", AttemptTally::kWindowSeconds,
                by_window.c_str());
  std::printf("memory: resident %.0f MiB now, peak %.0f MiB\n", rss, peak);
  if (output.empty()) return;
  std::filesystem::create_directories(output);
  std::ofstream csv(output + "/timeline.csv");
  csv << "seconds,frames,keyframes_added,keyframes_learned,backlog,resident_mib\n";
  for (const auto& row : stream.timeline)
    csv << row[0] << ',' << row[1] << ',' << row[2] << ',' << row[3] << ',' << row[4] << ','
        << row[5] << '\n';
  std::ofstream attempts_csv(output + "/relocalizations.csv");
  attempts_csv << "seconds,latency_ms,correct,wrong,keyframes_learned,frame\n";
  for (const Attempt& a : attempts)
    attempts_csv << a.at << ',' << 1000.0 * a.latency << ',' << a.correct << ',' << a.wrong << ','
                 << a.keyframes_learned << ',' << a.frame << '\n';
  nlohmann::json summary = {{"frames", stream.frames},
                            {"rate", stream.rate},
                            {"late_frames", stream.late},
                            {"worst_lag_s", stream.worst_lag},
                            {"keyframes_added", status.keyframes_added},
                            {"keyframes_stored", status.keyframes_stored},
                            {"retrains", status.retrains},
                            {"backlog", status.backlog},
                            {"attempts", attempts.size()},
                            {"correct", t.correct},
                            {"wrong", t.wrong},
                            {"attempts_correct_wrong_per_10s", t.windows},
                            {"first_correct_s", t.first_correct},
                            {"latency_median_ms", t.p50},
                            {"latency_p95_ms", t.p95},
                            {"resident_mib", rss},
                            {"peak_resident_mib", peak},
                            {"frames_untracked", stream.outcomes[0]},
                            {"frames_not_keyframes", stream.outcomes[1]},
                            {"frames_learned", stream.outcomes[2]},
                            {"frames_covered", stream.outcomes[3]},
                            {"frames_failed", stream.outcomes[4]},
                            {"frames_refused", stream.outcomes[5]}};
  if (submaps) {
    summary["submaps"] = submaps->submaps;
    summary["submap_keyframes"] = submaps->submap_keyframes;
    summary["keyframes_covered"] = submaps->keyframes_covered;
    summary["model_bytes_all_submaps"] = submaps->model_bytes;
    summary["freezes_pending_most"] = submaps->freezes_pending_most;
    summary["freeze_waits"] = submaps->freeze_waits;
    summary["freeze_wait_seconds"] = submaps->freeze_wait_seconds;
  }
  std::ofstream(output + "/summary.json") << summary.dump(2) << '\n';
}

// learn_benchmark's command line.
struct BenchOptions {
  cli::DatasetArguments arguments;
  std::string learn_frames, min_motion = formatMinMotion(KeyFrameMotion{}), learn_config, output,
                            learn_folder, model;
  double rate = 30.0, reloc_rate = 2.0, seconds = 60.0;
  int threads = 1;
  bool submaps = false;
  LearningParams learning;
  SubmapParams submap_rule;
};

void addOptions(cli::App& app, BenchOptions& o) {
  o.arguments.add(app, "Dataset folder with ground truth", "Held-out frames to relocalize");
  app.addOption("--learn-frames", o.learn_frames, "Frames streamed to the learner, in order")
      ->required();
  app.addOption("--rate", o.rate, "Stream rate, Hz")->range(0.1, 1000.0)->showDefault();
  app.addOption("--seconds", o.seconds, "Stream length, s (the learn frames loop)")
      ->range(1.0, 1e6)
      ->showDefault();
  app.addOption("--reloc-rate", o.reloc_rate, "Relocalizations per second (the node's max_rate)")
      ->range(0.01, 100.0)
      ->showDefault();
  app.addOption("--min-motion", o.min_motion, "Key frames: METRES,DEGREES")->showDefault();
  app.addFlag("--submaps", o.submaps,
              "Learn submaps (--max-keyframes each) and relocalize across them, as the node");
  app.addOption("--learn-folder", o.learn_folder,
                "With --submaps: the working folder, where frozen submaps are written as they "
                "freeze and their key frames leave memory, as in the node");
  app.addOption("--max-keyframes", o.learning.max_keyframes,
                "Cap on stored key frames (with --submaps: per submap)")
      ->range(2, 100000)
      ->showDefault();
  app.addOption("--learn-config", o.learn_config, "Training YAML for the retrains");
  app.addOption("--model", o.model,
                "Continue this saved place (with --submaps: a folder of learned submaps; "
                "without: a model saved with its key frames), as the node in learn mode with "
                "`model`");
  cli::addRelearnAgreement(app, o.submap_rule);
  app.addOption("-j,--threads", o.threads, "Threads of one relocalization")
      ->range(1, 1024)
      ->showDefault();
  app.addOption("-o,--output", o.output, "Folder for timeline.csv and summary.json");
}

// Submaps learned as the node learns them (continuing the saved place
// `model` when one is given), frozen ones written into `learn_folder` when one is given.
Expected<std::unique_ptr<SubmapLearner>> backgroundSubmaps(const LearningParams& learning,
                                                           const SubmapParams& rule,
                                                           const std::string& model,
                                                           const std::string& learn_folder) {
  auto learner = std::make_unique<SubmapLearner>(learning, rule, RelocalizerParams{}, SubmapNames{},
                                                 OnlineLearner::Mode::Background);
  if (!model.empty()) {
    auto resumed = learner->resume(model);
    if (!resumed) return makeError("--model: " + resumed.error());
    for (const std::string& warning : *resumed)
      std::fprintf(stderr, "learn_benchmark: %s\n", warning.c_str());
  }
  if (!learn_folder.empty())
    if (Status working = learner->useFolder(learn_folder); !working)
      return makeError("--learn-folder: " + working.error());
  return learner;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Streams --learn-frames of a dataset at --rate Hz (looped for --seconds) into a background "
      "online learner, as the node in learn mode receives them, while relocalizing --frames "
      "round-robin at --reloc-rate Hz on the current model. Prints whether the stream kept its "
      "rate, the stream time of the first correct relocalization (5 cm / 5 deg), relocalization "
      "latency, retrains and memory; --output writes timeline.csv and summary.json. --submaps "
      "learns submaps of --max-keyframes each, as the node does, and relocalizes across them.",
      "learn_benchmark"};
  BenchOptions o;
  addOptions(app, o);
  if (const cli::Exit done = app.parse(argc, argv)) return *done;
  auto checked = readLearningParams(o.learning, o.min_motion, o.learn_config);
  if (!checked) return cli::fail(app, "learning: " + checked.error());
  auto test = o.arguments.open();
  if (!test) return cli::fail(app, test.error());
  const cli::DatasetArguments& a = o.arguments;
  auto learn = cli::DatasetArguments{a.path, a.format, o.learn_frames, a.split}.open();
  if (!learn) return cli::fail(app, learn.error());
  const Dataset& test_data = **test;
  const Dataset& learn_data = **learn;
  // Test frames are read when used, as the node receives one frame at a time:
  // held in memory they would be most of the footprint measured.
  std::vector<size_t> test_frames;
  for (size_t i = 0; i < test_data.size(); ++i)
    if (test_data.groundTruth(i)) test_frames.push_back(i);
  if (test_frames.empty()) return cli::fail(app, "--frames: no frame with ground truth");
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<size_t>(o.threads) + 1);

  // One learner (a capped store) or submaps, as the node learns them.
  std::unique_ptr<OnlineLearner> one_store;
  std::unique_ptr<SubmapLearner> submaps;
  if (!o.learn_folder.empty() && !o.submaps)
    return cli::fail(app, "--learn-folder needs --submaps");
  // A continued set writes its frozen submaps into its working folder, which
  // would be the saved place itself: a benchmark leaves its input as it was.
  if (!o.model.empty() && o.submaps && o.learn_folder.empty())
    return cli::fail(app,
                     "--model with --submaps needs --learn-folder (the set learned on is "
                     "written there, not into the saved place)");
  if (std::string error = cli::relearnAgreementError(o.submap_rule, o.submaps); !error.empty())
    return cli::fail(app, error);
  if (o.submaps) {
    auto made = backgroundSubmaps(*checked, o.submap_rule, o.model, o.learn_folder);
    if (!made) return cli::fail(app, made.error());
    submaps = std::move(*made);
  } else {
    one_store = std::make_unique<OnlineLearner>(*checked, RelocalizerParams{},
                                                OnlineLearner::Mode::Background);
    if (!o.model.empty())
      if (Status resumed = one_store->resume(o.model); !resumed)
        return cli::fail(app, "--model: " + resumed.error());
  }
  Learner& learner = submaps ? static_cast<Learner&>(*submaps) : *one_store;
  KeyFrameFeed feed(learner, *checked);
  // The relocalizing thread's alone (its place set is not shared).
  Learned learned(learner);
  std::atomic<bool> done{false};
  const Clock::time_point start = Clock::now();

  std::vector<Attempt> attempts;
  std::thread relocalizing([&] {
    attempts = relocalizeUntilDone(test_data, test_frames, learned, o.reloc_rate, start, done);
  });

  Stream stream;
  stream.rate = o.rate;
  const std::string failure = streamFrames(
      learn_data.size(), o.seconds, start,
      [&](size_t i) {
        return feed.offer(learn_data.groundTruth(i), [&] { return learn_data.load(i); });
      },
      [&] {
        const LearnerSummary s = learner.summary();
        return std::array<double, 3>{static_cast<double>(s.keyframes_added),
                                     static_cast<double>(s.keyframes_learned),
                                     static_cast<double>(s.backlog)};
      },
      stream);
  done = true;
  relocalizing.join();  // also on a failure: a running std::thread may not be destroyed
  if (!failure.empty()) return cli::fail(app, failure);
  const std::optional<SubmapStatus> status =
      submaps ? std::optional(submaps->status()) : std::nullopt;
  report(stream, attempts, status ? status->active : one_store->status(),
         status ? &*status : nullptr, o.output);
  return 0;
}
