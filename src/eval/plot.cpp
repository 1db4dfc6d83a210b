#include "relocalizer/eval/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace relocalizer {

cv::Scalar plotColour(int index) {
  // Okabe-Ito palette, BGR.
  static const cv::Scalar kColours[] = {{178, 114, 0},  {0, 159, 230},   {115, 158, 0},
                                        {0, 94, 213},   {167, 121, 204}, {233, 180, 86},
                                        {66, 228, 240}, {0, 0, 0}};
  return kColours[index % 8];
}

namespace {

double niceStep(double range, int target_ticks) {
  const double raw = range / std::max(1, target_ticks);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (raw <= m * magnitude) return m * magnitude;
  return 10.0 * magnitude;
}

std::string tickText(double value, double step) {
  char buffer[32];
  if (std::abs(value) < step * 1e-6) value = 0.0;
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) + 1e-9)));
  std::snprintf(buffer, sizeof buffer, "%.*f", std::min(decimals, 6), value);
  return buffer;
}

void dashedLine(cv::Mat& image, cv::Point a, cv::Point b, const cv::Scalar& colour) {
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  const int dashes = std::max(1, static_cast<int>(length / 8));
  for (int i = 0; i < dashes; i += 2) {
    const double t0 = static_cast<double>(i) / dashes, t1 = static_cast<double>(i + 1) / dashes;
    cv::line(image, a + (b - a) * t0, a + (b - a) * t1, colour, 1, cv::LINE_AA);
  }
}

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kInk(40, 40, 40);

// The chart's data ranges and where they land in the image; y in log10 with log_y.
struct Axes {
  cv::Rect area;
  bool log_y = false;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;

  double transformY(double y) const { return log_y ? std::log10(std::max(y, 1e-12)) : y; }
  cv::Point toPixel(double x, double y) const {
    const double ty = transformY(y);
    return cv::Point(
        static_cast<int>(std::lround(area.x + (x - x0) / (x1 - x0) * area.width)),
        static_cast<int>(std::lround(area.y + area.height - (ty - y0) / (y1 - y0) * area.height)));
  }
};

// The ranges: fitted to the finite data with a little air, or fixed by the plot,
// and widened to one scale on both axes for maps.
Axes fitAxes(const Plot& plot, const cv::Rect& area) {
  Axes axes;
  axes.area = area;
  axes.log_y = plot.log_y;
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : plot.series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, axes.transformY(s.y[i]));
      y1 = std::max(y1, axes.transformY(s.y[i]));
    }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (std::isfinite(plot.x_min)) x0 = plot.x_min;
  if (std::isfinite(plot.x_max)) x1 = plot.x_max;
  if (std::isfinite(plot.y_min)) y0 = axes.transformY(plot.y_min);
  if (std::isfinite(plot.y_max)) y1 = axes.transformY(plot.y_max);
  if (x1 - x0 < 1e-12) x0 -= 0.5, x1 += 0.5;
  if (y1 - y0 < 1e-12) y0 -= 0.5, y1 += 0.5;
  // A little air around fitted data.
  if (!std::isfinite(plot.x_min) && !std::isfinite(plot.x_max)) {
    const double pad = 0.03 * (x1 - x0);
    x0 -= pad, x1 += pad;
  }
  if (!std::isfinite(plot.y_min) && !std::isfinite(plot.y_max)) {
    const double pad = 0.05 * (y1 - y0);
    y0 -= pad, y1 += pad;
  }
  if (plot.equal_axes) {
    const double sx = (x1 - x0) / area.width, sy = (y1 - y0) / area.height;
    const double s = std::max(sx, sy);
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    x0 = cx - 0.5 * s * area.width, x1 = cx + 0.5 * s * area.width;
    y0 = cy - 0.5 * s * area.height, y1 = cy + 0.5 * s * area.height;
  }
  axes.x0 = x0, axes.x1 = x1, axes.y0 = y0, axes.y1 = y1;
  return axes;
}

// Grid lines with their tick labels, the frame, and the dashed reference lines.
void drawGrid(cv::Mat& image, const Axes& axes, const Plot& plot) {
  const cv::Rect& area = axes.area;
  const double x0 = axes.x0, x1 = axes.x1, y0 = axes.y0, y1 = axes.y1;
  const bool log_y = axes.log_y;
  const cv::Scalar grid(230, 230, 230);
  const double x_step = niceStep(x1 - x0, 8), y_step = niceStep(y1 - y0, 6);
  for (double x = std::ceil(x0 / x_step) * x_step; x <= x1 + 1e-9; x += x_step) {
    const int px = axes.toPixel(x, log_y ? std::pow(10.0, y0) : y0).x;
    cv::line(image, {px, area.y}, {px, area.y + area.height}, grid, 1);
    const std::string t = tickText(x, x_step);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(t, kFont, 0.45, 1, &baseline);
    cv::putText(image, t, {px - size.width / 2, area.y + area.height + 18}, kFont, 0.45, kInk, 1,
                cv::LINE_AA);
  }
  for (double y = std::ceil(y0 / y_step) * y_step; y <= y1 + 1e-9; y += y_step) {
    const int py =
        static_cast<int>(std::lround(area.y + area.height - (y - y0) / (y1 - y0) * area.height));
    cv::line(image, {area.x, py}, {area.x + area.width, py}, grid, 1);
    const std::string t =
        log_y ? tickText(std::pow(10.0, y), std::pow(10.0, y) / 10) : tickText(y, y_step);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(t, kFont, 0.45, 1, &baseline);
    cv::putText(image, t, {area.x - size.width - 6, py + 5}, kFont, 0.45, kInk, 1, cv::LINE_AA);
  }
  cv::rectangle(image, area, kInk, 1);
  for (double y : plot.horizontal_lines)
    dashedLine(image, axes.toPixel(x0, y), axes.toPixel(x1, y), cv::Scalar(90, 90, 90));
  for (double x : plot.vertical_lines)
    dashedLine(image, {axes.toPixel(x, 1).x, area.y}, {axes.toPixel(x, 1).x, area.y + area.height},
               cv::Scalar(90, 90, 90));
}

// One series, clipped to the chart area: its line, markers and point labels.
void drawSeries(cv::Mat& image, const Axes& axes, const PlotSeries& s) {
  const cv::Rect& area = axes.area;
  cv::Mat clip = image(area);
  std::vector<cv::Point> run;
  const auto flush = [&] {
    if (s.line && run.size() > 1) {
      std::vector<cv::Point> shifted;
      for (const auto& p : run) shifted.push_back(p - area.tl());
      cv::polylines(clip, shifted, false, s.colour, s.thickness, cv::LINE_AA);
    }
    run.clear();
  };
  for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
      flush();  // gaps (frames without a pose) break the line
      continue;
    }
    const cv::Point p = axes.toPixel(s.x[i], s.y[i]);
    run.push_back(p);
    const cv::Point q = p - area.tl();
    if (s.marker == 1) cv::circle(clip, q, 3, s.colour, cv::FILLED, cv::LINE_AA);
    if (s.marker == 2) {
      cv::line(clip, q + cv::Point(-4, -4), q + cv::Point(4, 4), s.colour, 2, cv::LINE_AA);
      cv::line(clip, q + cv::Point(-4, 4), q + cv::Point(4, -4), s.colour, 2, cv::LINE_AA);
    }
    if (s.marker == 3) cv::circle(clip, q, 6, s.colour, 2, cv::LINE_AA);
    if (i < s.point_labels.size() && !s.point_labels[i].empty())
      cv::putText(clip, s.point_labels[i], q + cv::Point(8, -6), kFont, 0.45, s.colour, 1,
                  cv::LINE_AA);
  }
  flush();
}

// The title above the chart and the axis labels beside it (left: the margin's width).
void drawLabels(cv::Mat& image, const Plot& plot, const cv::Rect& area, int left) {
  const int height = image.rows;
  cv::putText(image, plot.title, {left, 28}, kFont, 0.65, kInk, 1, cv::LINE_AA);
  int baseline = 0;
  const cv::Size x_size = cv::getTextSize(plot.x_label, kFont, 0.5, 1, &baseline);
  cv::putText(image, plot.x_label, {area.x + (area.width - x_size.width) / 2, height - 15}, kFont,
              0.5, kInk, 1, cv::LINE_AA);
  // Vertical y label: draw horizontally, rotate, paste.
  const cv::Size y_size = cv::getTextSize(plot.y_label, kFont, 0.5, 1, &baseline);
  cv::Mat label(y_size.height + 8, y_size.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(label, plot.y_label, {2, y_size.height + 2}, kFont, 0.5, kInk, 1, cv::LINE_AA);
  cv::rotate(label, label, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int ly = std::max(0, area.y + (area.height - label.rows) / 2);
  if (label.rows + ly <= height && label.cols + 4 <= left)
    label.copyTo(image(cv::Rect(4, ly, label.cols, label.rows)));
}

// Legend, top right inside the chart.
void drawLegend(cv::Mat& image, const Plot& plot, const cv::Rect& area) {
  int row = 0, baseline = 0;
  for (const auto& s : plot.series) {
    if (s.label.empty()) continue;
    const cv::Size size = cv::getTextSize(s.label, kFont, 0.45, 1, &baseline);
    const int y = area.y + 16 + 18 * row++;
    const int x = area.x + area.width - size.width - 40;
    cv::rectangle(image, {x - 32, y - 12}, {area.x + area.width - 4, y + 5},
                  cv::Scalar(255, 255, 255), cv::FILLED);
    if (s.line) cv::line(image, {x - 28, y - 4}, {x - 8, y - 4}, s.colour, 2, cv::LINE_AA);
    if (s.marker) cv::circle(image, {x - 18, y - 4}, 3, s.colour, cv::FILLED, cv::LINE_AA);
    cv::putText(image, s.label, {x, y}, kFont, 0.45, kInk, 1, cv::LINE_AA);
  }
}

}  // namespace

cv::Mat Plot::render(int width, int height) const {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 80, right = 20, top = 45, bottom = 60;
  const cv::Rect area(left, top, width - left - right, height - top - bottom);
  const Axes axes = fitAxes(*this, area);
  drawGrid(image, axes, *this);
  for (const auto& s : series) drawSeries(image, axes, s);
  drawLabels(image, *this, area, left);
  drawLegend(image, *this, area);
  return image;
}

bool Plot::save(const std::string& path, int width, int height) const {
  return cv::imwrite(path, render(width, height));
}

}  // namespace relocalizer
