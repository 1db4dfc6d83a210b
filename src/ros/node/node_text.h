#pragma once
// How the node writes durations, stamps and counters into its log lines and
// ~result, so every part of it says them the same way.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace relocalizer_ros {

// A duration or rate: two decimals.
inline std::string secondsText(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", value);
  return text;
}

// A stamp to the millisecond, from integer nanoseconds (no double rounding,
// no ros::Time arithmetic on stamps that may be absurd).
inline std::string stampText(int64_t stamp_ns) {
  char text[40];
  std::snprintf(text, sizeof(text), "%lld.%03lld", static_cast<long long>(stamp_ns / 1'000'000'000),
                static_cast<long long>((stamp_ns % 1'000'000'000) / 1'000'000));
  return text;
}

// ~result's counters are uint32: a node up for years saturates, never wraps.
inline uint32_t saturate(uint64_t value) {
  return value > UINT32_MAX ? UINT32_MAX : static_cast<uint32_t>(value);
}

inline int64_t steadyNanoseconds() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace relocalizer_ros
