#include "relocalizer/eval/latency_benchmark.h"

#include <tbb/global_control.h>
#include <ctime>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "relocalizer/core/progress.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/plot.h"

namespace relocalizer {

namespace {

struct Stage {
  const char* name;
  StageTimingsField member;
};
const Stage kStages[] = {{"sampling_points", &StageTimings::sampling_points},
                         {"sampling_lines", &StageTimings::sampling_lines},
                         {"forest_points", &StageTimings::forest_points},
                         {"forest_lines", &StageTimings::forest_lines},
                         {"ransac", &StageTimings::ransac},
                         {"refinement", &StageTimings::refinement},
                         {"surface", &StageTimings::surface},
                         {"total", &StageTimings::total}};

std::string printed(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string printed(const char* format, ...) {
  char buffer[256];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  return buffer;
}

// Room above the data for the legend (top right), none lost at the right
// edge, and the two latency targets (50 ms, 30 Hz) as dashed lines.
void frameSweepPlot(Plot& plot) {
  double most_ms = 0, least_share = 100, most_share = 0;
  for (const PlotSeries& s : plot.series) {
    for (double x : s.x) most_ms = std::max(most_ms, x);
    for (double y : s.y)
      least_share = std::min(least_share, y), most_share = std::max(most_share, y);
  }
  plot.x_min = 0;
  plot.x_max = 1.08 * most_ms;
  plot.y_min = std::floor(least_share) - 2;
  plot.y_max = most_share + 0.45 * (most_share - plot.y_min);
  plot.vertical_lines = {1000.0 / 30.0, 50.0};
}

}  // namespace

ResidentMemory residentMemory() {
  ResidentMemory memory;
  std::ifstream status("/proc/self/status");
  std::string line;
  // "VmRSS:    12345 kB"
  const auto bytes = [&] { return std::stoull(line.substr(6)) * 1024ull; };
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) memory.current = bytes();
    if (line.rfind("VmHWM:", 0) == 0) memory.peak = bytes();
  }
  return memory;
}

double processCpuSeconds() {
  timespec now{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now) != 0) return 0.0;
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

Expected<std::vector<RgbdFrame>> loadAllFrames(const FrameSource& source) {
  std::vector<RgbdFrame> frames;
  ProgressBar bar("loading   ", source.size());
  for (size_t i = 0; i < source.size(); ++i) {
    auto frame = source.load(i);
    if (!frame) return makeError(frame.error());
    frames.push_back(std::move(*frame));
    bar.advance();
  }
  return frames;
}

TimedRun timeFrames(const Relocalizer& relocalizer, const std::vector<RgbdFrame>& frames,
                    int repeat, const std::string& progress_label) {
  TimedRun run;
  std::vector<EvaluationRecord> records;
  relocalizer.relocalize(frames.front());
  ProgressBar bar(progress_label, frames.size() * repeat);
  for (int r = 0; r < repeat; ++r)
    for (const RgbdFrame& frame : frames) {
      const Relocalization result = relocalizer.relocalize(frame);
      run.timings.push_back(result.timings);
      if (r == 0 && frame.ground_truth)
        records.push_back(recordAttempt(frame.id, frame.stamp, *frame.ground_truth, result));
      bar.advance();
    }
  run.accuracy = summarizeAccuracy(records);
  return run;
}

std::vector<TimedRun> timeThreadCounts(const Relocalizer& relocalizer,
                                       const std::vector<RgbdFrame>& frames,
                                       const std::vector<int>& thread_counts, int repeat) {
  std::vector<TimedRun> runs;
  for (int t : thread_counts) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, t);
    runs.push_back(timeFrames(relocalizer, frames, repeat, std::to_string(t) + " thread(s)"));
    runs.back().threads = t;
  }
  return runs;
}

std::string formatStageTableHead(const std::vector<int>& thread_counts) {
  std::string out = printed("%-18s", "stage (ms)");
  for (int t : thread_counts) out += printed("  %d thread%s median / p95", t, t == 1 ? " " : "s");
  return out + "\n";
}

std::string formatStageTableRows(const std::vector<TimedRun>& runs) {
  std::string out;
  for (const Stage& stage : kStages) {
    out += printed("%-18s", stage.name);
    for (const TimedRun& run : runs) {
      const LatencySummary l = stageLatency(run.timings, stage.member);
      out += printed("  %14.1f / %-8.1f", l.median_ms, l.p95_ms);
    }
    out += "\n";
  }
  out += printed("%-18s", "within 5cm/5deg");
  for (const TimedRun& run : runs)
    out += printed("  %14.1f %%         ", 100 * run.accuracy.within_5cm_5deg);
  return out + "\n";
}

nlohmann::json timedRunsJson(const std::vector<TimedRun>& runs) {
  nlohmann::json out;
  for (const TimedRun& run : runs) {
    nlohmann::json j;
    for (const Stage& stage : kStages) {
      const LatencySummary l = stageLatency(run.timings, stage.member);
      j[stage.name] = {{"median_ms", l.median_ms}, {"p95_ms", l.p95_ms}};
    }
    j["within_5cm_5deg"] = run.accuracy.within_5cm_5deg;
    out[std::to_string(run.threads)] = j;
  }
  return out;
}

Expected<nlohmann::json> speedAccuracySweep(const Model& model, const RelocalizerParams& params,
                                            const std::vector<RgbdFrame>& frames,
                                            const std::string& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) return makeError(folder + ": cannot create the sweep folder: " + ec.message());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
  const std::vector<int> pixel_counts = {250, 500, 1000, 2000, 4000};
  const std::vector<int> hypothesis_counts = {64, 256, 1024};
  std::ofstream csv(folder + "/sweep.csv");
  csv << "point_samples,line_samples,hypotheses,median_ms,p95_ms,within_5cm_5deg,within_2cm_2deg,"
         "median_translation_cm,median_rotation_deg\n";
  Plot plot;
  plot.title = "speed vs accuracy, 1 thread (line samples = points / 2; dashed: 30 Hz, 50 ms)";
  plot.x_label = "median ms per frame";
  plot.y_label = "share of frames (%): 5 cm / 5 deg (lines), 2 cm / 2 deg (crosses)";
  nlohmann::json points = nlohmann::json::array();
  int colour = 0;
  for (int hypotheses : hypothesis_counts) {
    PlotSeries series = PlotSeries::styled(std::to_string(hypotheses) + " hypotheses, 5 cm / 5 deg",
                                           plotColour(colour), true, 1);
    PlotSeries tight = PlotSeries::styled(std::to_string(hypotheses) + " hypotheses, 2 cm / 2 deg",
                                          plotColour(colour++), false, 2);
    for (int pixels : pixel_counts) {
      RelocalizerParams p = params;
      p.point_samples = pixels;
      p.line_samples = pixels / 2;
      p.solver.hypotheses = hypotheses;
      const Relocalizer variant(model, p);
      const TimedRun run = timeFrames(
          variant, frames, 1, "sweep " + std::to_string(pixels) + "/" + std::to_string(hypotheses));
      const LatencySummary total = stageLatency(run.timings, &StageTimings::total);
      const AccuracySummary& a = run.accuracy;
      csv << pixels << "," << pixels / 2 << "," << hypotheses << "," << total.median_ms << ","
          << total.p95_ms << "," << a.within_5cm_5deg << "," << a.within_2cm_2deg << ","
          << 100 * a.median_translation_m << "," << a.median_rotation_deg << "\n";
      tight.x.push_back(total.median_ms);
      tight.y.push_back(100 * a.within_2cm_2deg);
      series.x.push_back(total.median_ms);
      series.y.push_back(100 * a.within_5cm_5deg);
      const bool is_default =
          pixels == params.point_samples && hypotheses == params.solver.hypotheses;
      series.point_labels.push_back(std::to_string(pixels) + (is_default ? " (default)" : ""));
      points.push_back({{"point_samples", pixels},
                        {"hypotheses", hypotheses},
                        {"median_ms", total.median_ms},
                        {"within_5cm_5deg", a.within_5cm_5deg},
                        {"within_2cm_2deg", a.within_2cm_2deg}});
    }
    plot.series.push_back(series);
    plot.series.push_back(tight);
  }
  frameSweepPlot(plot);
  if (!csv) return makeError(folder + "/sweep.csv: cannot write");
  if (!plot.save(folder + "/sweep.png", 1000, 650))
    return makeError(folder + "/sweep.png: cannot write");
  return points;
}

}  // namespace relocalizer
