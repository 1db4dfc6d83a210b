#include "relocalizer/eval/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "relocalizer/core/statistics.h"
#include "relocalizer/eval/plot.h"

namespace relocalizer {

namespace {

std::string number(double value, const char* format) {
  if (std::isnan(value)) return "n/a";
  if (std::isinf(value)) return "inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

nlohmann::json jsonNumber(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

EvaluationRecord recordAttempt(int id, double stamp, const Pose& truth,
                               const Relocalization& result) {
  EvaluationRecord r;
  r.id = id;
  r.stamp = stamp;
  r.truth = truth;
  if (result.success) r.estimate = result.pose;
  r.message = result.message;
  r.point_inliers = result.point_inliers;
  r.line_inliers = result.line_inliers;
  r.score = result.score;
  r.surface_agreement = result.surface_agreement;
  r.light_cast = result.light_cast;
  r.second_draw = result.second_draw;
  r.timings = result.timings;
  return r;
}

EvaluationRecord recordAttempt(int id, double stamp, const Pose& truth, const PlaceAnswer& answer) {
  EvaluationRecord r = recordAttempt(id, stamp, truth, answer.relocalization);
  r.place = answer.place;
  return r;
}

int countWrongPlace(const std::vector<EvaluationRecord>& records, const std::string& expected) {
  int wrong = 0;
  for (const auto& r : records) wrong += !r.place.empty() && r.place != expected ? 1 : 0;
  return wrong;
}

LatencySummary stageLatency(const std::vector<StageTimings>& timings, StageTimingsField stage) {
  std::vector<double> ms;
  for (const auto& t : timings) ms.push_back(1000.0 * (t.*stage));
  return {median(ms), percentile(ms, 95.0)};
}

AccuracySummary summarizeAccuracy(const std::vector<EvaluationRecord>& records) {
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (const auto& r : records) {
    errors.push_back(frameError(r.id, r.estimate, r.truth));
    estimates.push_back(r.estimate);
    truths.push_back(r.truth);
  }
  return summarizeAccuracy(errors, estimates, truths);
}

EvaluationSummary summarizeEvaluation(const std::vector<EvaluationRecord>& records,
                                      const std::string& expected_place) {
  std::vector<StageTimings> timings;
  for (const auto& r : records) timings.push_back(r.timings);
  EvaluationSummary s;
  s.accuracy = summarizeAccuracy(records);
  for (const auto& r : records) {
    if (r.light_cast > 0.0f) {
      ++s.asked_in_training_light;
      s.answered_in_training_light += r.estimate ? 1 : 0;
    }
    if (r.second_draw) {
      ++s.drawn_again;
      s.confirmed_by_second_draw += r.estimate ? 1 : 0;
    }
  }
  if (!expected_place.empty()) {
    s.expected_place = expected_place;
    s.wrong_place = countWrongPlace(records, expected_place);
  }
  s.screening = stageLatency(timings, &StageTimings::screening);
  s.total = stageLatency(timings, &StageTimings::total);
  s.sampling = stageLatency(timings, &StageTimings::sampling);
  s.forest = stageLatency(timings, &StageTimings::forest);
  s.ransac = stageLatency(timings, &StageTimings::ransac);
  s.refinement = stageLatency(timings, &StageTimings::refinement);
  s.surface = stageLatency(timings, &StageTimings::surface);
  return s;
}

std::string formatEvaluationTable(const EvaluationSummary& s, const std::string& title) {
  const AccuracySummary& a = s.accuracy;
  std::ostringstream out;
  out << title << "\n";
  out << "  frames                     " << a.frames << "\n";
  out << "  within 5 cm / 5 deg        " << number(100.0 * a.within_5cm_5deg, "%.1f %%") << "\n";
  out << "  within 2 cm / 2 deg        " << number(100.0 * a.within_2cm_2deg, "%.1f %%") << "\n";
  out << "  median error               " << number(100.0 * a.median_translation_m, "%.2f cm")
      << " / " << number(a.median_rotation_deg, "%.2f deg") << "\n";
  out << "  ATE RMSE (Horn-aligned)    " << number(100.0 * a.ate_rmse_m, "%.2f cm") << "\n";
  out << "  frames with no pose        " << (a.frames - a.frames_with_pose) << "\n";
  if (s.asked_in_training_light > 0)
    out << "  asked again in the training light " << s.asked_in_training_light << " ("
        << s.answered_in_training_light << " answered)\n";
  if (s.drawn_again > 0)
    out << "  weak answers drawn again   " << s.drawn_again << " (" << s.confirmed_by_second_draw
        << " confirmed)\n";
  char wrong_label[64];
  std::snprintf(wrong_label, sizeof wrong_label, "wrong (> %g cm or %g deg)",
                100.0 * kWrongPose.metres, kWrongPose.degrees);
  out << "  " << std::left << std::setw(27) << wrong_label << a.wrong_answers << "\n";
  if (s.wrong_place >= 0) {
    // The label column of the rows above is 27 characters wide.
    const std::string label = "wrong place (not " + s.expected_place + ")";
    out << "  " << label
        << std::string(std::max<size_t>(1, 27 - std::min<size_t>(27, label.size())), ' ')
        << s.wrong_place << "\n";
  }
  out << "  latency, median / p95 (ms)\n";
  const auto row = [&](const char* name, const LatencySummary& l) {
    out << "    " << name << number(l.median_ms, "%8.1f") << " / " << number(l.p95_ms, "%.1f")
        << "\n";
  };
  row("whole call   ", s.total);
  row("sampling     ", s.sampling);
  row("forests      ", s.forest);
  row("RANSAC       ", s.ransac);
  row("refinement   ", s.refinement);
  row("surface (ICP)", s.surface);
  if (s.screening.median_ms > 0) row("place screen ", s.screening);
  return out.str();
}

namespace {

// The first column of poses.txt and places.csv: 7-Scenes' frame number or the stamp.
std::string stampColumn(const EvaluationRecord& r, const EvaluationOutputOptions& options) {
  char text[64];
  if (options.integer_stamps)
    std::snprintf(text, sizeof text, "%d", r.id);
  else
    std::snprintf(text, sizeof text, "%.6f", r.stamp);
  return text;
}

Status writePoses(const std::string& path, const std::vector<EvaluationRecord>& records,
                  const EvaluationOutputOptions& options) {
  std::ofstream poses(path);
  if (!poses) return makeError(path + ": cannot open for writing");
  poses << "# timestamp tx ty tz qx qy qz qw (camera-to-world; frames without a pose left out)\n";
  for (const auto& r : records) {
    if (!r.estimate) continue;
    const Eigen::Quaterniond q(r.estimate->linear());
    const Eigen::Vector3d t = r.estimate->translation();
    char line[256];
    std::snprintf(line, sizeof line, " %.6f %.6f %.6f %.7f %.7f %.7f %.7f\n", t.x(), t.y(), t.z(),
                  q.x(), q.y(), q.z(), q.w());
    poses << stampColumn(r, options) << line;
  }
  return okStatus();
}

Status writePlaces(const std::string& path, const std::vector<EvaluationRecord>& records,
                   const EvaluationOutputOptions& options) {
  std::ofstream places(path);
  if (!places) return makeError(path + ": cannot open for writing");
  places << "# timestamp place (the answering place; empty: no pose)\n";
  for (const auto& r : records) places << stampColumn(r, options) << " " << r.place << "\n";
  return okStatus();
}

Status writeErrors(const std::string& path, const std::vector<EvaluationRecord>& records) {
  std::ofstream csv(path);
  if (!csv) return makeError(path + ": cannot open for writing");
  csv << "id,stamp,has_pose,translation_error_m,rotation_error_deg,point_inliers,line_inliers,"
         "score,surface_agreement,total_ms,sampling_ms,forest_ms,ransac_ms,refinement_ms,"
         "surface_ms,message\n";
  for (const auto& r : records) {
    const FrameError e = frameError(r.id, r.estimate, r.truth);
    std::string message = r.message;
    for (char& c : message)
      if (c == '"') c = '\'';
    // The message is streamed, not formatted: a reason asked twice (in the
    // training light, by a second draw) runs past any fixed line.
    char line[320];
    std::snprintf(
        line, sizeof line, "%d,%.6f,%d,%s,%s,%d,%d,%.4f,%s,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,", r.id,
        r.stamp, e.has_pose ? 1 : 0, e.has_pose ? number(e.translation_m, "%.5f").c_str() : "",
        e.has_pose ? number(e.rotation_deg, "%.4f").c_str() : "", r.point_inliers, r.line_inliers,
        r.score, r.surface_agreement >= 0 ? number(r.surface_agreement, "%.4f").c_str() : "",
        1000 * r.timings.total, 1000 * r.timings.sampling, 1000 * r.timings.forest,
        1000 * r.timings.ransac, 1000 * r.timings.refinement, 1000 * r.timings.surface);
    csv << line << '"' << message << "\"\n";
  }
  return okStatus();
}

Status writeSummary(const std::string& path, const EvaluationSummary& summary,
                    const EvaluationOutputOptions& options) {
  const AccuracySummary& a = summary.accuracy;
  nlohmann::json j;
  j["title"] = options.title;
  j["frames"] = a.frames;
  j["frames_with_pose"] = a.frames_with_pose;
  j["frames_without_pose"] = a.frames - a.frames_with_pose;
  j["within_5cm_5deg"] = jsonNumber(a.within_5cm_5deg);
  j["within_2cm_2deg"] = jsonNumber(a.within_2cm_2deg);
  j["wrong_answers"] = a.wrong_answers;
  j["asked_in_training_light"] = summary.asked_in_training_light;
  j["answered_in_training_light"] = summary.answered_in_training_light;
  j["drawn_again"] = summary.drawn_again;
  j["confirmed_by_second_draw"] = summary.confirmed_by_second_draw;
  j["median_translation_cm"] = jsonNumber(100.0 * a.median_translation_m);
  j["median_rotation_deg"] = jsonNumber(a.median_rotation_deg);
  j["ate_rmse_cm"] = jsonNumber(100.0 * a.ate_rmse_m);
  if (summary.wrong_place >= 0) {
    j["expected_place"] = summary.expected_place;
    j["wrong_place"] = summary.wrong_place;
  }
  const auto lat = [](const LatencySummary& l) {
    return nlohmann::json{{"median_ms", jsonNumber(l.median_ms)}, {"p95_ms", jsonNumber(l.p95_ms)}};
  };
  j["latency"] = {{"total", lat(summary.total)},           {"sampling", lat(summary.sampling)},
                  {"forest", lat(summary.forest)},         {"ransac", lat(summary.ransac)},
                  {"refinement", lat(summary.refinement)}, {"surface", lat(summary.surface)}};
  if (options.places) j["latency"]["screening"] = lat(summary.screening);
  if (!options.extra_json.empty()) {
    try {
      j.update(nlohmann::json::parse(options.extra_json));
    } catch (const std::exception& e) {
      return makeError(std::string("summary.json extra fields are not valid JSON: ") + e.what());
    }
  }
  std::ofstream out(path);
  if (!out) return makeError(path + ": cannot open for writing");
  out << j.dump(2) << "\n";
  return okStatus();
}

// Top view: the plane of the two largest ground-truth extents (7-Scenes'
// vertical axis is not fixed, so pick it from the data).
Status writeTrajectoryPlot(const std::string& path, const std::vector<EvaluationRecord>& records,
                           const std::string& title) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const auto& r : records) {
    lo = lo.cwiseMin(r.truth.translation());
    hi = hi.cwiseMax(r.truth.translation());
  }
  const Eigen::Vector3d extent = hi - lo;
  int up = 0;
  extent.minCoeff(&up);
  const int ax = up == 0 ? 1 : 0, ay = up == 2 ? 1 : 2;
  const char* names = "xyz";
  Plot top;
  top.title = title + ": top view (ground truth, estimates, frames without a pose)";
  top.x_label = std::string(1, names[ax]) + " (m)";
  top.y_label = std::string(1, names[ay]) + " (m)";
  top.equal_axes = true;
  auto truth = PlotSeries::styled("ground truth", cv::Scalar(60, 60, 60), true, 0, 2);
  auto good = PlotSeries::styled("estimate within 5 cm / 5 deg", plotColour(2), false, 1, 1);
  auto bad = PlotSeries::styled("estimate outside", plotColour(3), false, 2, 1);
  auto none = PlotSeries::styled("no pose (at ground truth)", plotColour(4), false, 3, 1);
  for (const auto& r : records) {
    truth.x.push_back(r.truth.translation()[ax]);
    truth.y.push_back(r.truth.translation()[ay]);
    if (!r.estimate) {
      none.x.push_back(r.truth.translation()[ax]);
      none.y.push_back(r.truth.translation()[ay]);
      continue;
    }
    const FrameError e = frameError(r.id, r.estimate, r.truth);
    PlotSeries& target = within(e, kCorrectPose) ? good : bad;
    // Estimates far off the map would squash the picture; clamp them to its edge.
    Eigen::Vector3d p = r.estimate->translation();
    const Eigen::Vector3d margin =
        Eigen::Vector3d::Constant(std::max(0.5, extent.maxCoeff() * 0.5));
    p = p.cwiseMax(lo - margin).cwiseMin(hi + margin);
    target.x.push_back(p[ax]);
    target.y.push_back(p[ay]);
  }
  top.series = {truth, good, bad, none};
  if (!top.save(path, 900, 800)) return makeError(path + ": cannot write");
  return okStatus();
}

Status writeErrorPlot(const std::string& path, const std::vector<EvaluationRecord>& records,
                      const std::string& title) {
  Plot errors;
  errors.title = title + ": error per frame (no pose = gap)";
  errors.x_label = "frame";
  errors.y_label = "translation error (cm), rotation error (deg)";
  errors.log_y = true;
  errors.y_min = 0.05;
  errors.horizontal_lines = {5.0};
  auto t_series = PlotSeries::styled("translation (cm)", plotColour(0), true, 1, 1);
  auto r_series = PlotSeries::styled("rotation (deg)", plotColour(1), true, 1, 1);
  for (const auto& record : records) {
    const FrameError e = frameError(record.id, record.estimate, record.truth);
    t_series.x.push_back(record.id);
    r_series.x.push_back(record.id);
    t_series.y.push_back(e.has_pose ? std::max(100.0 * e.translation_m, 0.05) : NAN);
    r_series.y.push_back(e.has_pose ? std::max(e.rotation_deg, 0.05) : NAN);
  }
  errors.series = {t_series, r_series};
  if (!errors.save(path, 1100, 500)) return makeError(path + ": cannot write");
  return okStatus();
}

}  // namespace

Status writeEvaluationOutputs(const std::string& folder,
                              const std::vector<EvaluationRecord>& records,
                              const EvaluationSummary& summary,
                              const EvaluationOutputOptions& options) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) return makeError(folder + ": cannot create output folder: " + ec.message());
  for (const Status& written :
       {writePoses(folder + "/poses.txt", records, options),
        options.places ? writePlaces(folder + "/places.csv", records, options) : okStatus(),
        writeErrors(folder + "/errors.csv", records),
        writeSummary(folder + "/summary.json", summary, options),
        writeTrajectoryPlot(folder + "/trajectory.png", records, options.title),
        writeErrorPlot(folder + "/errors.png", records, options.title)})
    if (!written) return written;
  return okStatus();
}

}  // namespace relocalizer
