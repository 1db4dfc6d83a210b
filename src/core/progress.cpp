#include "relocalizer/core/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace relocalizer {

ProgressBar::ProgressBar(std::string label, size_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {
  if (enabled_) draw(0, false);
}

ProgressBar::~ProgressBar() { finish(); }

bool ProgressBar::terminalAttached() { return ::isatty(STDERR_FILENO) == 1; }

std::string ProgressBar::formatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--";
  const long s = std::lround(seconds);
  char buffer[32];
  if (s >= 3600)
    std::snprintf(buffer, sizeof buffer, "%ldh%02ldm", s / 3600, (s % 3600) / 60);
  else if (s >= 60)
    std::snprintf(buffer, sizeof buffer, "%ldm%02lds", s / 60, s % 60);
  else
    std::snprintf(buffer, sizeof buffer, "%lds", s);
  return buffer;
}

void ProgressBar::advance(size_t steps) {
  const size_t done = done_.fetch_add(steps) + steps;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  // Redraw at most 10 times a second; the terminal is not the bottleneck.
  std::unique_lock<std::mutex> lock(draw_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  if (done < total_.load() && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  draw(done, false);
}

void ProgressBar::finish() {
  std::lock_guard<std::mutex> lock(draw_mutex_);
  if (finished_) return;
  finished_ = true;
  if (enabled_) draw(done_.load(), true);
}

void ProgressBar::draw(size_t done, bool final_draw) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const size_t total = total_.load();
  const double fraction = total ? std::min(1.0, static_cast<double>(done) / total) : 1.0;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(filled, '#');
  bar.resize(kWidth, '.');
  const double eta = done > 0 ? elapsed * (total - std::min(done, total)) / done : NAN;
  std::fprintf(stderr, "\r%s [%s] %zu/%zu %3.0f%%  elapsed %s  ETA %s   ", label_.c_str(),
               bar.c_str(), done, total, fraction * 100.0, formatDuration(elapsed).c_str(),
               final_draw ? "0s" : formatDuration(eta).c_str());
  if (final_draw) std::fputc('\n', stderr);
  std::fflush(stderr);
}

}  // namespace relocalizer
