#pragma once
// Rate limiting for log lines about bad input, per reason: a camera sending the
// wrong encoding at 30 Hz logs once every few seconds, yet a different fault
// appearing meanwhile is still reported at once (ROS_WARN_THROTTLE would hide
// it behind the first, as it throttles per call site).

#include <chrono>
#include <map>
#include <mutex>
#include <string>

namespace relocalizer_ros {

class ThrottledLog {
 public:
  explicit ThrottledLog(double period_seconds = 5.0) : period_(period_seconds) {}

  // True when `reason` was not allowed through within the period; the caller
  // then logs it. Reasons are keyed by their text, so callers should keep
  // varying numbers (stamps, counts) out of the key.
  bool allow(const std::string& reason) {
    const auto now = std::chrono::steady_clock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    auto [it, inserted] = last_.try_emplace(reason, now);
    if (!inserted) {
      if (std::chrono::duration<double>(now - it->second).count() < period_) return false;
      it->second = now;
    }
    // Keep memory bounded if reasons do vary.
    if (last_.size() > 256) last_.clear();
    return true;
  }

 private:
  const double period_;
  std::mutex mutex_;
  std::map<std::string, std::chrono::steady_clock::time_point> last_;
};

}  // namespace relocalizer_ros
