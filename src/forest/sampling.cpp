#include "relocalizer/forest/sampling.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "relocalizer/forest/line_detector_input.h"
#include "relocalizer/forest/line_segment_detector.h"

namespace relocalizer {

namespace {

inline bool validDepth(float d) { return d == d && d > 0.0f; }

Sample makeSample(const RgbdFrame& frame, int u, int v, float depth) {
  Sample s;
  s.u = static_cast<int16_t>(u);
  s.v = static_cast<int16_t>(v);
  s.depth = depth;
  s.camera_point = frame.camera.backProject(static_cast<float>(u), static_cast<float>(v), depth);
  return s;
}

// Segment endpoints in the detector input's pixels, as (x1, y1, x2, y2).
std::vector<cv::Vec4f> openCvLsdSegments(const cv::Mat& colour, float scale) {
  cv::Mat gray;
  cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
  cv::Mat lsd_input = gray;
  if (scale < 1.0f) cv::resize(gray, lsd_input, cv::Size(), scale, scale, cv::INTER_AREA);
  std::vector<cv::Vec4f> segments;
  try {
    // LSD's own internal scaling is disabled (scale 1): we control it above.
    cv::Ptr<cv::LineSegmentDetector> lsd = cv::createLineSegmentDetector(cv::LSD_REFINE_NONE, 1.0);
    lsd->detect(lsd_input, segments);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("line_sampling.line_detector: opencv_lsd, but OpenCV " CV_VERSION
                             " has no working LSD (4.1.0 to 4.5.3 ship a stub that throws)");
  }
  return segments;
}

std::vector<cv::Vec4f> ownSegments(const cv::Mat& colour, float scale, bool validate) {
  std::vector<cv::Vec4f> segments;
  for (const LineSegment& s : detectLineSegments(lineDetectorInput(colour, scale), validate))
    segments.emplace_back(static_cast<float>(s.x1), static_cast<float>(s.y1),
                          static_cast<float>(s.x2), static_cast<float>(s.y2));
  return segments;
}

}  // namespace

const char* lineDetectorName(LineDetector detector) {
  return detector == LineDetector::kOwn ? "own" : "opencv_lsd";
}

std::optional<LineDetector> lineDetectorNamed(const std::string& name) {
  for (LineDetector d : {LineDetector::kOwn, LineDetector::kOpenCvLsd})
    if (name == lineDetectorName(d)) return d;
  return std::nullopt;
}

std::vector<cv::Vec4f> detectSegments(const cv::Mat& colour, LineDetector detector, float scale,
                                      bool lsd_validation) {
  return detector == LineDetector::kOwn ? ownSegments(colour, scale, lsd_validation)
                                        : openCvLsdSegments(colour, scale);
}

std::string lineDetectorMissing(LineDetector detector) {
  static const std::string opencv_missing = [] {
    try {
      openCvLsdSegments(cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(0)), 1.0f);
      return std::string();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  }();
  return detector == LineDetector::kOpenCvLsd ? opencv_missing : std::string();
}

void samplePoints(const RgbdFrame& frame, int count, std::mt19937& rng, std::vector<Sample>& out) {
  const cv::Mat& depth = frame.depth;
  const int width = depth.cols, height = depth.rows;
  if (count <= 0 || width == 0) return;
  // Rejection sampling is fast when most depth is valid; a bounded number of
  // tries keeps nearly-empty depth images from spinning.
  std::uniform_int_distribution<int> pick_u(0, width - 1), pick_v(0, height - 1);
  const int max_tries = count * 20;
  int taken = 0;
  for (int tries = 0; taken < count && tries < max_tries; ++tries) {
    const int u = pick_u(rng), v = pick_v(rng);
    const float d = depth.ptr<float>(v)[u];
    if (!validDepth(d)) continue;
    out.push_back(makeSample(frame, u, v, d));
    ++taken;
  }
}

bool fitLineRansac(const std::vector<Eigen::Vector3f>& points, float inlier_threshold,
                   int iterations, std::mt19937& rng, Line3D& line, std::vector<int>& inliers) {
  const int n = static_cast<int>(points.size());
  inliers.clear();
  if (n < 2) return false;
  std::uniform_int_distribution<int> pick(0, n - 1);
  int best_count = 0;
  Line3D best;
  for (int it = 0; it < iterations; ++it) {
    const int a = pick(rng), b = pick(rng);
    const Eigen::Vector3f dir = points[b] - points[a];
    const float length = dir.norm();
    if (a == b || length < 1e-4f) continue;
    const Line3D candidate{points[a], dir / length};
    int count = 0;
    for (const auto& p : points) count += candidate.distance(p) < inlier_threshold ? 1 : 0;
    if (count > best_count) {
      best_count = count;
      best = candidate;
    }
  }
  if (best_count < 2) return false;
  // Least-squares refit (principal axis) on the inliers, then re-select them.
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  std::vector<int> chosen;
  for (int i = 0; i < n; ++i)
    if (best.distance(points[i]) < inlier_threshold) {
      chosen.push_back(i);
      mean += points[i];
    }
  mean /= static_cast<float>(chosen.size());
  Eigen::Matrix3f scatter = Eigen::Matrix3f::Zero();
  for (int i : chosen) scatter += (points[i] - mean) * (points[i] - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> eig(scatter);
  line.point = mean;
  line.direction = eig.eigenvectors().col(2).normalized();
  for (int i = 0; i < n; ++i)
    if (line.distance(points[i]) < inlier_threshold) inliers.push_back(i);
  return inliers.size() >= 2;
}

float lsdScaleFor(const LineSamplingParams& params, int image_width) {
  float scale = std::clamp(params.lsd_scale, 0.1f, 1.0f);
  if (params.lsd_min_width_px > 0 && image_width > 0 &&
      scale * static_cast<float>(image_width) < static_cast<float>(params.lsd_min_width_px))
    scale = std::min(1.0f, static_cast<float>(params.lsd_min_width_px) / image_width);
  return scale;
}

LineSamples sampleLines(const RgbdFrame& frame, const LineSamplingParams& params, int max_samples,
                        std::mt19937& rng) {
  LineSamples result;
  const float scale = lsdScaleFor(params, frame.colour.cols);
  const std::vector<cv::Vec4f> segments =
      detectSegments(frame.colour, params.line_detector, scale, params.lsd_validation);
  result.segments_detected = static_cast<int>(segments.size());

  const int width = frame.depth.cols, height = frame.depth.rows;
  std::vector<Eigen::Vector3f> points;
  std::vector<Sample> candidates;
  std::vector<int> inliers;
  for (const cv::Vec4f& raw : segments) {
    const Eigen::Vector2f a(raw[0] / scale, raw[1] / scale), b(raw[2] / scale, raw[3] / scale);
    const float length = (b - a).norm();
    if (length < params.min_segment_length_px) continue;
    const int steps = std::max(2, static_cast<int>(length / params.spacing_px) + 1);
    Eigen::Vector2f normal(-(b - a).y(), (b - a).x());
    normal /= length;
    points.clear();
    candidates.clear();
    const int sides = params.edge_offset_px > 0.0f ? 2 : 1;
    for (int side = 0; side < sides; ++side) {
      const float offset = side == 0 ? params.edge_offset_px : -params.edge_offset_px;
      const Eigen::Vector2f shift = normal * (sides == 2 ? offset : 0.0f);
      for (int i = 0; i < steps; ++i) {
        const Eigen::Vector2f p = a + (b - a) * (static_cast<float>(i) / (steps - 1)) + shift;
        const int u = static_cast<int>(std::lround(p.x())),
                  v = static_cast<int>(std::lround(p.y()));
        if (u < 0 || v < 0 || u >= width || v >= height) continue;
        const float d = frame.depth.ptr<float>(v)[u];
        if (!validDepth(d)) continue;
        candidates.push_back(makeSample(frame, u, v, d));
        points.push_back(candidates.back().camera_point);
      }
    }
    if (static_cast<int>(points.size()) < params.min_inliers) continue;
    Line3D line;
    if (!fitLineRansac(points, params.ransac_inlier_m, params.ransac_iterations, rng, line,
                       inliers))
      continue;
    if (static_cast<int>(inliers.size()) < params.min_inliers ||
        inliers.size() < params.min_inlier_ratio * points.size())
      continue;
    const int line_index = static_cast<int>(result.lines.size());
    result.lines.push_back(line);
    for (int i : inliers) {
      candidates[i].line = line_index;
      result.samples.push_back(candidates[i]);
    }
  }
  result.segments_kept = static_cast<int>(result.lines.size());
  if (max_samples > 0 && static_cast<int>(result.samples.size()) > max_samples) {
    // Partial Fisher-Yates: an unbiased subset without sorting everything.
    for (int i = 0; i < max_samples; ++i) {
      std::uniform_int_distribution<int> pick(i, static_cast<int>(result.samples.size()) - 1);
      std::swap(result.samples[i], result.samples[pick(rng)]);
    }
    result.samples.resize(max_samples);
  }
  return result;
}

}  // namespace relocalizer
