#pragma once
// evaluate --learn-frames' learning curve: a point every --curve-every learn
// frames (accuracy on --frames after a retrain), drawn to learning_curve.png
// and listed in summary.json, whether one store or submaps learned.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "relocalizer/core/expected.h"
#include "relocalizer/eval/plot.h"

namespace relocalizer::cli {

class LearningCurve {
 public:
  explicit LearningCurve(const std::string& dataset_path) : series_(styledSeries()) {
    plot_.title = "learning curve: " + std::filesystem::path(dataset_path).filename().string();
    plot_.x_label = "frames learned";
    plot_.y_label = "% within 5 cm / 5 deg";
    plot_.y_min = 0.0;
    plot_.y_max = 100.0;
  }

  // One point; `figures` (key frames, retrain seconds, ...) go into its JSON row.
  void add(int frames_learned, double within_5cm_5deg, nlohmann::json figures) {
    figures["frames_learned"] = frames_learned;
    figures["within_5cm_5deg"] = within_5cm_5deg;
    json_.push_back(std::move(figures));
    series_.x.push_back(frames_learned);
    series_.y.push_back(100.0 * within_5cm_5deg);
  }

  const nlohmann::json& json() const { return json_; }

  // OUTPUT/learning_curve.png; nothing without an output folder.
  Status save(const std::string& output) const {
    if (output.empty()) return okStatus();
    std::filesystem::create_directories(output);
    Plot plot = plot_;
    plot.series.push_back(series_);
    const std::string path = output + "/learning_curve.png";
    if (!plot.save(path)) return makeError(path + ": cannot write");
    return okStatus();
  }

 private:
  static PlotSeries styledSeries() {
    return PlotSeries::styled("online model", plotColour(0), true, 1);
  }

  Plot plot_;
  PlotSeries series_;
  nlohmann::json json_ = nlohmann::json::array();
};

}  // namespace relocalizer::cli
