// line_detector_benchmark: the line sampling's detector stage alone (the
// detector's input from the colour image, then the segments), our own LSD
// against OpenCV's, on dataset frames: median and 95th-percentile ms per frame
// on one thread, and how many segments each finds.

#include <algorithm>
#include <chrono>
#include <cmath>

#include "cli_support.h"
#include "relocalizer/forest/sampling.h"
#include "source_arguments.h"

using namespace relocalizer;

namespace {

struct Detector {
  const char* name;
  LineDetector detector;
  bool lsd_validation;
};

struct DetectorFigures {
  std::vector<double> ms;
  long segments = 0, long_segments = 0;
};

double percentile(std::vector<double> values, double share) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(share * (values.size() - 1) + 0.5)];
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Times the line detector stage of line sampling (grey, downscale, segments) on dataset "
      "frames, our own LSD as configured by default (lsd_validation false), validated (true) "
      "and OpenCV's (where this OpenCV has it), alternating frame by frame on one thread; prints "
      "median / 95th percentile ms per frame and the segments found "
      "(all, and those at least min_segment_length_px long in the frame).",
      "line_detector_benchmark"};
  cli::SourceOptions source_options;
  source_options.add(app, "Dataset folder", "Frame ids (default: all)");
  int rounds = 5;
  app.addOption("--rounds", rounds, "Timed runs of each detector per frame (the median is kept)")
      ->range(1, 100)
      ->showDefault();
  if (const cli::Exit done = app.parse(argc, argv)) return *done;
  auto source = source_options.open();
  if (!source) return cli::fail(app, source.error());
  const FrameSource& data = **source;

  const LineSamplingParams params;
  std::vector<Detector> detectors{{"own", LineDetector::kOwn, false},
                                  {"own+nfa", LineDetector::kOwn, true}};
  if (lineDetectorMissing(LineDetector::kOpenCvLsd).empty())
    detectors.push_back({"opencv_lsd", LineDetector::kOpenCvLsd, false});
  std::vector<DetectorFigures> figures(detectors.size());
  for (size_t i = 0; i < data.size(); ++i) {
    auto frame = data.load(i);
    if (!frame) return cli::fail(app, frame.error());
    const float scale = lsdScaleFor(params, frame->colour.cols);
    std::vector<std::vector<double>> runs(detectors.size());
    for (int round = 0; round < rounds; ++round)
      for (size_t d = 0; d < detectors.size(); ++d) {
        const auto start = std::chrono::steady_clock::now();
        const std::vector<cv::Vec4f> segments = detectSegments(frame->colour, detectors[d].detector,
                                                               scale, detectors[d].lsd_validation);
        runs[d].push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count());
        if (round > 0) continue;
        figures[d].segments += static_cast<long>(segments.size());
        for (const cv::Vec4f& s : segments)
          figures[d].long_segments +=
              std::hypot(s[2] - s[0], s[3] - s[1]) / scale >= params.min_segment_length_px;
      }
    for (size_t d = 0; d < detectors.size(); ++d) figures[d].ms.push_back(percentile(runs[d], 0.5));
  }
  std::printf("%zu frames, %d rounds each, one thread\n", data.size(), rounds);
  std::printf("%-12s %10s %10s %16s %22s\n", "detector", "median ms", "p95 ms", "segments/frame",
              "long segments/frame");
  for (size_t d = 0; d < detectors.size(); ++d)
    std::printf("%-12s %10.3f %10.3f %16.1f %22.1f\n", detectors[d].name,
                percentile(figures[d].ms, 0.5), percentile(figures[d].ms, 0.95),
                static_cast<double>(figures[d].segments) / data.size(),
                static_cast<double>(figures[d].long_segments) / data.size());
  std::printf("own: lsd_validation false (the default); own+nfa: true (density check and NFA)\n");
  if (detectors.back().detector == LineDetector::kOwn)
    std::printf("opencv_lsd: %s\n", lineDetectorMissing(LineDetector::kOpenCvLsd).c_str());
  return 0;
}
