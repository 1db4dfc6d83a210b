#pragma once
// Hand-over of synchronised frames from the subscription callbacks to the
// threads that relocalize them (the continuous worker and service calls).
// push() never waits for a consumer, so a slow relocalization cannot hold up
// the callbacks, and the `Latest` policy keeps one pending frame, so latency
// cannot grow: a frame replaced before it was taken is counted as dropped.
// `Fifo` keeps every frame for exact replays (~process_all), trading bounded
// latency for completeness.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>

namespace relocalizer_ros {

template <typename T>
class FrameBuffer {
 public:
  enum class Policy { Latest, Fifo };
  using Clock = std::chrono::steady_clock;

  struct Entry {
    uint64_t seq = 0;  // 1, 2, ... in push order
    T value;
  };

  explicit FrameBuffer(Policy policy) : policy_(policy) {}

  void push(T value) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      Entry entry{++last_seq_, std::move(value)};
      if (policy_ == Policy::Latest && !pending_.empty()) {
        pending_.clear();
        ++dropped_;
      }
      pending_.push_back(entry);
      latest_ = std::move(entry);
    }
    changed_.notify_all();
  }

  // The consumer side of the queue: waits for a frame not taken yet and takes
  // it (the oldest under Fifo, the only one under Latest). Empty when closed.
  std::optional<Entry> take() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return closed_ || !pending_.empty(); });
    if (closed_) return std::nullopt;
    Entry entry = std::move(pending_.front());
    pending_.pop_front();
    return entry;
  }

  // The newest frame pushed after sequence number `after` (0: any frame),
  // whether or not a consumer took it, waiting for it until `deadline`. Empty
  // on timeout or close. Service calls read frames this way, so several calls
  // may share one frame and none steals it from the continuous worker.
  std::optional<Entry> newest(uint64_t after, Clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto ready = [&] { return latest_ && latest_->seq > after; };
    changed_.wait_until(lock, deadline, [&] { return closed_ || ready(); });
    if (closed_ || !ready()) return std::nullopt;
    return latest_;
  }

  // Forgets every frame not taken yet (counted as dropped) and the latest
  // one, so that neither the worker nor a service call uses a frame from
  // before a time jump. Sequence numbers go on, so a call waiting for a
  // frame after `lastSeq()` still waits for a new one. Returns how many
  // pending frames were dropped.
  size_t clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    const size_t count = pending_.size();
    pending_.clear();
    dropped_ += count;
    latest_.reset();
    return count;
  }

  uint64_t lastSeq() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_seq_;
  }

  uint64_t dropped() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return dropped_;
  }

  size_t pendingCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pending_.size();
  }

  // Sleeps until `deadline` unless closed first; returns false when closed.
  // Lets the worker rate-limit itself without missing a shutdown.
  bool sleepUntil(Clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    return !closed_wait_.wait_until(lock, deadline, [this] { return closed_; });
  }

  // Wakes every waiter; later waits return at once.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    changed_.notify_all();
    closed_wait_.notify_all();
  }

 private:
  const Policy policy_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::condition_variable closed_wait_;
  std::deque<Entry> pending_;
  std::optional<Entry> latest_;
  uint64_t last_seq_ = 0;
  uint64_t dropped_ = 0;
  bool closed_ = false;
};

}  // namespace relocalizer_ros
