#include "relocalizer/forest/mean_shift.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace relocalizer {

namespace {
constexpr float kExpfZeroBelow = -104.0f;
}

std::vector<Mode3D> meanShiftModes(const std::vector<Eigen::Vector3f>& points,
                                   const MeanShiftParams& params, std::vector<int>* assignment) {
  const int n = static_cast<int>(points.size());
  if (assignment) assignment->assign(n, -1);
  if (n == 0) return {};
  const float inv_two_sigma2 = 1.0f / (2.0f * params.bandwidth * params.bandwidth);
  const float converged2 = 1e-6f * params.bandwidth * params.bandwidth;
  const float merge2 = 0.25f * params.bandwidth * params.bandwidth;  // within h/2

  const int seeds = std::min(n, std::max(1, params.max_seeds));
  std::vector<Eigen::Vector3f> peaks;
  for (int s = 0; s < seeds; ++s) {
    Eigen::Vector3f x = points[static_cast<size_t>(s) * n / seeds];
    for (int it = 0; it < params.max_iterations; ++it) {
      Eigen::Vector3f weighted = Eigen::Vector3f::Zero();
      float total = 0.0f;
      for (const auto& p : points) {
        const float exponent = -(p - x).squaredNorm() * inv_two_sigma2;
        // expf is exactly 0 below -104 (under the smallest subnormal), where
        // libm takes its slow underflow path: the same sums without the call.
        if (exponent < kExpfZeroBelow) continue;
        const float w = std::exp(exponent);
        weighted += w * p;
        total += w;
      }
      if (total <= 0.0f) break;
      const Eigen::Vector3f next = weighted / total;
      const float moved2 = (next - x).squaredNorm();
      x = next;
      if (moved2 < converged2) break;
    }
    bool merged = false;
    for (const auto& peak : peaks)
      if ((peak - x).squaredNorm() < merge2) {
        merged = true;
        break;
      }
    if (!merged) peaks.push_back(x);
  }

  // Each point joins its nearest peak; statistics per peak.
  const int k = static_cast<int>(peaks.size());
  std::vector<int> owner(n);
  std::vector<int> count(k, 0);
  for (int i = 0; i < n; ++i) {
    int best = 0;
    float best_d = (points[i] - peaks[0]).squaredNorm();
    for (int j = 1; j < k; ++j) {
      const float d = (points[i] - peaks[j]).squaredNorm();
      if (d < best_d) {
        best_d = d;
        best = j;
      }
    }
    owner[i] = best;
    ++count[best];
  }
  std::vector<int> order(k);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return count[a] > count[b]; });

  std::vector<Mode3D> modes;
  std::vector<int> new_index(k, -1);
  const float min_support = std::max(1.0f, params.min_mode_share * n);
  for (int j : order) {
    if (static_cast<int>(modes.size()) >= params.max_modes || count[j] < min_support) break;
    new_index[j] = static_cast<int>(modes.size());
    modes.emplace_back();
  }
  std::vector<Eigen::Vector3d> sums(modes.size(), Eigen::Vector3d::Zero());
  std::vector<Eigen::Matrix3d> squares(modes.size(), Eigen::Matrix3d::Zero());
  for (int i = 0; i < n; ++i) {
    const int m = new_index[owner[i]];
    if (assignment) (*assignment)[i] = m;
    if (m < 0) continue;
    const Eigen::Vector3d p = points[i].cast<double>();
    sums[m] += p;
    squares[m] += p * p.transpose();
    ++modes[m].support;
  }
  const double floor = static_cast<double>(params.min_std) * params.min_std;
  for (size_t m = 0; m < modes.size(); ++m) {
    const double c = modes[m].support;
    const Eigen::Vector3d mean = sums[m] / c;
    Eigen::Matrix3d cov = squares[m] / c - mean * mean.transpose();
    cov = 0.5 * (cov + cov.transpose());
    cov += floor * Eigen::Matrix3d::Identity();
    modes[m].mean = mean.cast<float>();
    modes[m].covariance = cov.cast<float>();
  }
  return modes;
}

}  // namespace relocalizer
