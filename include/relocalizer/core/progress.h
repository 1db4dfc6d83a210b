#pragma once
// A one-line progress bar with rate and ETA for long offline work (training,
// evaluation, synthesis). It draws only when stderr is a terminal, so logs and
// CI output stay clean; thread-safe `advance()` lets parallel loops report.

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>

namespace relocalizer {

class ProgressBar {
 public:
  // `enabled` = false silences it; by default it follows isatty(stderr).
  ProgressBar(std::string label, size_t total, bool enabled = terminalAttached());
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void advance(size_t steps = 1);
  // For work whose size is learnt on the way (training samples are drawn per forest).
  void addToTotal(size_t steps) { total_ += steps; }
  // Ends the line; called by the destructor if needed.
  void finish();

  static bool terminalAttached();
  // "1h02m", "3m07s", "12s".
  static std::string formatDuration(double seconds);

 private:
  void draw(size_t done, bool final_draw);

  std::string label_;
  std::atomic<size_t> total_;
  bool enabled_;
  std::atomic<size_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::mutex draw_mutex_;
  bool finished_ = false;
};

}  // namespace relocalizer
