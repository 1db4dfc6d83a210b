#pragma once
// Small PNG charts drawn with OpenCV, for the pictures the tools write
// (trajectories, per-frame errors, sweeps, threshold curves). No plotting
// stack is needed on the machine; the charts are deterministic.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace relocalizer {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  cv::Scalar colour{200, 80, 30};  // BGR
  bool line = true;                // join points with a line
  int marker = 0;                  // 0 none, 1 dot, 2 cross, 3 ring
  int thickness = 2;
  std::vector<std::string> point_labels;  // optional text beside each point

  static PlotSeries styled(std::string label, cv::Scalar colour, bool line, int marker,
                           int thickness = 2) {
    PlotSeries s;
    s.label = std::move(label);
    s.colour = colour;
    s.line = line;
    s.marker = marker;
    s.thickness = thickness;
    return s;
  }
};

struct Plot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  bool equal_axes = false;  // same scale on x and y (maps, trajectories)
  bool log_y = false;
  // Fixed axis ranges; NaN = fit the data.
  double x_min = NAN, x_max = NAN, y_min = NAN, y_max = NAN;
  std::vector<double> horizontal_lines;  // dashed reference lines at these y
  std::vector<double> vertical_lines;    // and x

  cv::Mat render(int width = 900, int height = 600) const;
  // Writes a PNG; false on failure.
  bool save(const std::string& path, int width = 900, int height = 600) const;
};

// Distinct, colour-blind friendly series colours (BGR), by index.
cv::Scalar plotColour(int index);

}  // namespace relocalizer
