#include "relocalizer/data/registration.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

namespace relocalizer {

ColourRegistration ColourRegistration::sevenScenesKinect() {
  ColourRegistration r;
  r.fx = r.fy = 521.5;
  r.cx = 321.5;
  r.cy = 237.0;
  r.depth_to_colour = Eigen::Vector3d(0.025, 0.0, 0.0);
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

// Frame pairs: nearly the same viewpoint tells nothing about the registration
// (both frames misread colour the same way); very different ones rarely see
// the same surfaces.
constexpr double kMinBaseline = 0.05;  // metres, or
constexpr double kMinAngle = 3.0;      // degrees between the views
constexpr double kMaxBaseline = 2.0;
constexpr double kMaxAngle = 60.0;
constexpr int kPartnersPerFrame = 8;
constexpr float kMinGradient = 40.0f;     // Sobel magnitude of a textured pixel
constexpr float kDepthAgreement = 0.02f;  // metres: the point is visible in both frames
constexpr double kTruncation = 30.0;      // grey levels: occlusions and specularities

double bilinear(const cv::Mat& image, double u, double v) {
  const int iu = static_cast<int>(u), iv = static_cast<int>(v);
  const double fu = u - iu, fv = v - iv;
  const float* r0 = image.ptr<float>(iv);
  const float* r1 = image.ptr<float>(iv + 1);
  return (1 - fv) * ((1 - fu) * r0[iu] + fu * r0[iu + 1]) +
         fv * ((1 - fu) * r1[iu] + fu * r1[iu + 1]);
}

// Where the colour camera sees a point of the depth camera, or false if outside.
bool colourPixel(const ColourRegistration& r, const Eigen::Vector3f& point, const cv::Mat& image,
                 double& u, double& v) {
  const Eigen::Vector3d p = point.cast<double>() - r.depth_to_colour;
  if (p.z() <= 0.0) return false;
  u = r.fx * p.x() / p.z() + r.cx;
  v = r.fy * p.y() / p.z() + r.cy;
  return u >= 0 && v >= 0 && u < image.cols - 1 && v < image.rows - 1;
}

}  // namespace

PhotometricConsistency::PhotometricConsistency(const std::vector<PosedRgbd>& frames,
                                               const CameraIntrinsics& depth_camera,
                                               int samples_per_pair) {
  std::vector<cv::Mat> gradients;
  for (const PosedRgbd& f : frames) {
    CV_Assert(f.colour.type() == CV_8UC3 && f.depth.type() == CV_32FC1);
    cv::Mat grey, gx, gy, magnitude;
    cv::cvtColor(f.colour, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(grey, CV_32F);
    // A little blur: the comparison should tolerate sub-pixel depth and pose noise.
    cv::GaussianBlur(grey, grey, cv::Size(5, 5), 1.0);
    grey_.push_back(grey);
    cv::Sobel(grey, gx, CV_32F, 1, 0);
    cv::Sobel(grey, gy, CV_32F, 0, 1);
    cv::magnitude(gx, gy, magnitude);
    gradients.push_back(magnitude);
  }
  std::mt19937 rng(3);
  const int n = static_cast<int>(frames.size());
  for (int i = 0; i < n; ++i) {
    const cv::Mat& depth = frames[i].depth;
    // Textured pixels are found in the colour image at the same pixel: any
    // registration within ~20 px of the truth finds texture there too.
    const cv::Mat& gradient = gradients[i];
    std::vector<int> partners;
    for (int j = 0; j < n; ++j) {
      const Pose relative = frames[j].pose.inverse() * frames[i].pose;
      const double baseline = relative.translation().norm();
      const double angle = Eigen::AngleAxisd(relative.linear()).angle() * 180.0 / M_PI;
      if (j != i && (baseline > kMinBaseline || angle > kMinAngle) && baseline < kMaxBaseline &&
          angle < kMaxAngle)
        partners.push_back(j);
    }
    // At most kPartnersPerFrame, spread over the candidates (which follow the frame order).
    const size_t stride = std::max<size_t>(1, partners.size() / kPartnersPerFrame);
    for (size_t p = 0; p < partners.size(); p += stride) {
      const int j = partners[p];
      const Pose i_to_j = frames[j].pose.inverse() * frames[i].pose;
      int found = 0;
      for (int attempt = 0; attempt < 20 * samples_per_pair && found < samples_per_pair;
           ++attempt) {
        const int u = 10 + static_cast<int>(rng() % static_cast<unsigned>(depth.cols - 20));
        const int v = 10 + static_cast<int>(rng() % static_cast<unsigned>(depth.rows - 20));
        const float z = depth.at<float>(v, u);
        if (!(z > 0.0f)) continue;
        if (v >= gradient.rows || u >= gradient.cols || gradient.at<float>(v, u) < kMinGradient)
          continue;  // untextured: any registration reads the same grey there
        const Eigen::Vector3f a =
            depth_camera.backProject(static_cast<float>(u), static_cast<float>(v), z);
        const Eigen::Vector3f b = (i_to_j.cast<float>() * a);
        if (b.z() < 0.3f) continue;
        const Eigen::Vector2f q = depth_camera.project(b);
        const int uj = static_cast<int>(std::lround(q.x())),
                  vj = static_cast<int>(std::lround(q.y()));
        if (uj < 0 || vj < 0 || uj >= depth.cols || vj >= depth.rows) continue;
        const float zj = frames[j].depth.at<float>(vj, uj);
        if (!(zj > 0.0f) || std::abs(zj - b.z()) > kDepthAgreement) continue;
        pairs_.push_back({a, b, i, j});
        ++found;
      }
    }
  }
}

double PhotometricConsistency::cost(const ColourRegistration& registration) const {
  if (pairs_.empty()) return 0.0;
  double sum = 0.0;
  for (const Correspondence& c : pairs_) {
    double ua, va, ub, vb;
    // A point the registration maps outside either image costs the truncation,
    // so the search cannot win by pushing points out of view.
    if (!colourPixel(registration, c.a, grey_[c.i], ua, va) ||
        !colourPixel(registration, c.b, grey_[c.j], ub, vb)) {
      sum += kTruncation;
      continue;
    }
    sum += std::min(kTruncation,
                    std::abs(bilinear(grey_[c.i], ua, va) - bilinear(grey_[c.j], ub, vb)));
  }
  return sum / static_cast<double>(pairs_.size());
}

ColourRegistration estimateColourRegistration(const std::vector<PosedRgbd>& frames,
                                              const CameraIntrinsics& depth_camera,
                                              const ColourRegistration& initial, bool fit_offset,
                                              double* cost, double* initial_cost) {
  const PhotometricConsistency consistency(frames, depth_camera);
  ColourRegistration best = initial;
  double best_cost = consistency.cost(best);
  if (initial_cost) *initial_cost = best_cost;
  // Parameters and first steps: focal length and principal point in pixels,
  // offsets in metres. Four rounds halve the steps down to 0.5 px / 1.25 mm.
  double steps[5] = {4.0, 2.0, 2.0, 0.01, 0.01};
  for (int round = 0; round < 4; ++round) {
    for (bool improved = true; improved;) {
      improved = false;
      for (int k = 0; k < (fit_offset ? 5 : 3); ++k)
        for (const double sign : {-1.0, 1.0}) {
          ColourRegistration candidate = best;
          double* const candidate_parameters[5] = {&candidate.fx, &candidate.cx, &candidate.cy,
                                                   &candidate.depth_to_colour.x(),
                                                   &candidate.depth_to_colour.y()};
          *candidate_parameters[k] += sign * steps[k];
          candidate.fy = candidate.fx;
          const double c = consistency.cost(candidate);
          if (c < best_cost - 1e-9) {
            best = candidate;
            best_cost = c;
            improved = true;
          }
        }
    }
    for (double& s : steps) s /= 2.0;
  }
  if (cost) *cost = best_cost;
  return best;
}

}  // namespace relocalizer
