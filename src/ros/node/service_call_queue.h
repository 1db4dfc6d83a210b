#pragma once
// A callback queue for service calls that lets no call hold up another, and
// tells each call when it arrived.
//
// roscpp answers a service call on whichever thread runs its callback, and
// ~relocalize may wait seconds for the next frame. On a queue with a fixed
// number of spinner threads, a few long waits held every thread, and calls
// behind them were neither answered nor timed from their arrival (50 calls
// asking for 1 s were answered after 12.9 s, each saying "within 1.00 s").
// Here every call gets a thread of its own as it arrives (up to
// `max_threads`, reused when idle), and callAge() lets a call that did queue
// count its wait from its arrival.

#include <ros/callback_queue_interface.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

namespace relocalizer_ros {

class ServiceCallQueue : public ros::CallbackQueueInterface {
 public:
  using Clock = std::chrono::steady_clock;

  explicit ServiceCallQueue(size_t max_threads);
  ~ServiceCallQueue() override;
  ServiceCallQueue(const ServiceCallQueue&) = delete;
  ServiceCallQueue& operator=(const ServiceCallQueue&) = delete;

  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t owner_id) override;
  void removeByID(uint64_t owner_id) override;
  // Runs what is queued, then ends the threads; later calls are not run.
  void stop();

  // On a thread of this queue, inside a call: when that call arrived.
  // Elsewhere: now.
  static Clock::time_point callArrival();

 private:
  struct Call {
    ros::CallbackInterfacePtr callback;
    uint64_t owner_id;
    Clock::time_point arrival;
  };
  void run();

  const size_t max_threads_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Call> calls_;
  std::vector<std::thread> threads_;
  size_t idle_ = 0;
  bool stopping_ = false;
};

}  // namespace relocalizer_ros
