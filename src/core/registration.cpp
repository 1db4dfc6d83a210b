#include "relocalizer/registration.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace relocalizer {

ColourRegistration ColourRegistration::sevenScenesKinect() {
  ColourRegistration r;
  r.fx = r.fy = 527.0;
  r.cx = 322.0;
  r.cy = 239.0;
  r.depth_to_colour = Eigen::Vector3d(-0.03, 0.0, 0.0);
  return r;
}

cv::Mat registerColourToDepth(const cv::Mat& colour, const cv::Mat& depth_metres,
                              const CameraIntrinsics& depth_camera,
                              const ColourRegistration& registration) {
  CV_Assert(colour.type() == CV_8UC3 && depth_metres.type() == CV_32FC1);
  cv::Mat map_x(depth_metres.size(), CV_32FC1), map_y(depth_metres.size(), CV_32FC1);
  const Eigen::Vector3d& t = registration.depth_to_colour;
  for (int v = 0; v < depth_metres.rows; ++v) {
    const float* d = depth_metres.ptr<float>(v);
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    for (int u = 0; u < depth_metres.cols; ++u) {
      const double z = (d[u] == d[u] && d[u] > 0) ? d[u] : registration.fallback_depth;
      // Point in the depth camera, then in the colour camera (pure translation).
      const double x = (u - depth_camera.cx) * z / depth_camera.fx - t.x();
      const double y = (v - depth_camera.cy) * z / depth_camera.fy - t.y();
      const double zc = z - t.z();
      mx[u] = static_cast<float>(registration.fx * x / zc + registration.cx);
      my[u] = static_cast<float>(registration.fy * y / zc + registration.cy);
    }
  }
  cv::Mat out;
  cv::remap(colour, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

namespace {

struct EdgePixel {
  float u, v, z;
  int frame;
};

}  // namespace

ColourRegistration estimateColourRegistration(const std::vector<cv::Mat>& colours,
                                              const std::vector<cv::Mat>& depths,
                                              const CameraIntrinsics& depth_camera, double* score,
                                              double* identity_score) {
  std::vector<cv::Mat> gradients;
  std::vector<EdgePixel> edges;
  for (size_t i = 0; i < colours.size() && i < depths.size(); ++i) {
    cv::Mat gray, gx, gy, magnitude;
    cv::cvtColor(colours[i], gray, cv::COLOR_BGR2GRAY);
    cv::GaussianBlur(gray, gray, cv::Size(3, 3), 0);
    cv::Sobel(gray, gx, CV_32F, 1, 0);
    cv::Sobel(gray, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, magnitude);
    gradients.push_back(magnitude);
    const cv::Mat& d = depths[i];
    // The near side of depth discontinuities: its silhouette is a colour edge too.
    for (int v = 1; v + 1 < d.rows; ++v)
      for (int u = 1; u + 1 < d.cols; ++u) {
        const float z = d.at<float>(v, u);
        if (!(z > 0)) continue;
        const float around[4] = {d.at<float>(v, u - 1), d.at<float>(v, u + 1), d.at<float>(v - 1, u),
                                 d.at<float>(v + 1, u)};
        bool edge = false;
        for (float n : around) edge = edge || n > z + 0.08f;
        if (edge) edges.push_back({static_cast<float>(u), static_cast<float>(v), z, static_cast<int>(i)});
      }
  }
  const auto evaluate = [&](double f, double cx, double cy, double tx) {
    double sum = 0;
    long count = 0;
    for (const EdgePixel& e : edges) {
      const double x = (e.u - depth_camera.cx) * e.z / depth_camera.fx - tx;
      const double y = (e.v - depth_camera.cy) * e.z / depth_camera.fy;
      const int u = static_cast<int>(std::lround(f * x / e.z + cx));
      const int v = static_cast<int>(std::lround(f * y / e.z + cy));
      const cv::Mat& g = gradients[e.frame];
      if (u < 0 || v < 0 || u >= g.cols || v >= g.rows) continue;
      sum += g.at<float>(v, u);
      ++count;
    }
    return count ? sum / count : 0.0;
  };
  if (identity_score) *identity_score = evaluate(depth_camera.fx, depth_camera.cx, depth_camera.cy, 0);
  // Coarse grid on focal length and principal point, then x offset and a finer grid.
  double best = -1, bf = depth_camera.fx, bx = depth_camera.cx, by = depth_camera.cy, bt = 0;
  for (double f = 0.8 * depth_camera.fx; f <= 1.05 * depth_camera.fx; f += 5)
    for (double cx = depth_camera.cx - 20; cx <= depth_camera.cx + 20; cx += 2)
      for (double cy = depth_camera.cy - 20; cy <= depth_camera.cy + 20; cy += 2) {
        const double s = evaluate(f, cx, cy, 0);
        if (s > best) best = s, bf = f, bx = cx, by = cy;
      }
  const double f0 = bf, x0 = bx, y0 = by;
  for (double tx = -0.06; tx <= 0.06 + 1e-9; tx += 0.01)
    for (double f = f0 - 6; f <= f0 + 6; f += 1)
      for (double cx = x0 - 12; cx <= x0 + 12; cx += 1)
        for (double cy = y0 - 3; cy <= y0 + 3; cy += 1) {
          const double s = evaluate(f, cx, cy, tx);
          if (s > best) best = s, bf = f, bx = cx, by = cy, bt = tx;
        }
  ColourRegistration r;
  r.fx = r.fy = bf;
  r.cx = bx;
  r.cy = by;
  r.depth_to_colour = Eigen::Vector3d(bt, 0, 0);
  if (score) *score = best;
  return r;
}

}  // namespace relocalizer
