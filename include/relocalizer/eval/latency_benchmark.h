#pragma once
// The latency benchmark: per-stage times of Relocalizer::relocalize over
// preloaded frames, per thread count, and the speed-accuracy sweep over
// sampled pixels and RANSAC hypotheses (the `benchmark` tool's figures).

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "relocalizer/core/expected.h"
#include "relocalizer/data/frame_source.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer {

// The CPU's model name from /proc/cpuinfo, for the record.
std::string cpuModel();

// This process's resident memory (Linux /proc/self/status), bytes.
struct ResidentMemory {
  uint64_t current = 0;  // VmRSS
  uint64_t peak = 0;     // VmHWM
};
ResidentMemory residentMemory();

// CPU seconds (user + system) this process's threads have used so far: with
// a wall time, how much of a machine a piece of work took.
double processCpuSeconds();

// Every frame of `source`, in order, so timing never waits on the disk.
Expected<std::vector<RgbdFrame>> loadAllFrames(const FrameSource& source);

struct TimedRun {
  int threads = 1;
  std::vector<StageTimings> timings;  // every call, every pass
  AccuracySummary accuracy;           // the first pass, frames with ground truth
};

// `repeat` passes over `frames` after one untimed call (the model paged in,
// TBB's workers awake), at the current TBB parallelism.
TimedRun timeFrames(const Relocalizer& relocalizer, const std::vector<RgbdFrame>& frames,
                    int repeat, const std::string& progress_label);

// One run per thread count (TBB limited to it).
std::vector<TimedRun> timeThreadCounts(const Relocalizer& relocalizer,
                                       const std::vector<RgbdFrame>& frames,
                                       const std::vector<int>& thread_counts, int repeat);

// The printed table: its head before the runs, its rows after.
std::string formatStageTableHead(const std::vector<int>& thread_counts);
std::string formatStageTableRows(const std::vector<TimedRun>& runs);
// {"<threads>": {"<stage>": {"median_ms", "p95_ms"}, ..., "within_5cm_5deg"}, ...}
nlohmann::json timedRunsJson(const std::vector<TimedRun>& runs);

// One thread, every combination of point samples (line samples = half) and
// hypotheses: writes sweep.csv and sweep.png into `folder` and returns the
// points as a JSON array.
Expected<nlohmann::json> speedAccuracySweep(const Model& model, const RelocalizerParams& params,
                                            const std::vector<RgbdFrame>& frames,
                                            const std::string& folder);

}  // namespace relocalizer
