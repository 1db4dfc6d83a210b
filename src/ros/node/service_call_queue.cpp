#include "service_call_queue.h"

#include <algorithm>

namespace relocalizer_ros {

namespace {

thread_local bool t_in_call = false;
thread_local ServiceCallQueue::Clock::time_point t_arrival;

}  // namespace

ServiceCallQueue::ServiceCallQueue(size_t max_threads)
    : max_threads_(std::max<size_t>(1, max_threads)) {}

ServiceCallQueue::~ServiceCallQueue() { stop(); }

void ServiceCallQueue::addCallback(const ros::CallbackInterfacePtr& callback, uint64_t owner_id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    calls_.push_back({callback, owner_id, Clock::now()});
    // A thread per waiting call, so that one call's wait never delays another
    // (threads blocked on a condition variable cost a stack each, no CPU).
    if (idle_ < calls_.size() && threads_.size() < max_threads_)
      threads_.emplace_back([this] { run(); });
  }
  wake_.notify_one();
}

void ServiceCallQueue::removeByID(uint64_t owner_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  calls_.erase(std::remove_if(calls_.begin(), calls_.end(),
                              [owner_id](const Call& call) { return call.owner_id == owner_id; }),
               calls_.end());
}

void ServiceCallQueue::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& thread : threads_)
    if (thread.joinable()) thread.join();
  threads_.clear();
}

ServiceCallQueue::Clock::time_point ServiceCallQueue::callArrival() {
  return t_in_call ? t_arrival : Clock::now();
}

void ServiceCallQueue::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    ++idle_;
    wake_.wait(lock, [this] { return stopping_ || !calls_.empty(); });
    --idle_;
    if (calls_.empty()) return;  // stopping, nothing left to answer
    Call call = std::move(calls_.front());
    calls_.pop_front();
    lock.unlock();
    t_in_call = true;
    t_arrival = call.arrival;
    const ros::CallbackInterface::CallResult result =
        call.callback->ready() ? call.callback->call() : ros::CallbackInterface::TryAgain;
    t_in_call = false;
    lock.lock();
    if (result == ros::CallbackInterface::TryAgain && !stopping_) calls_.push_back(std::move(call));
  }
}

}  // namespace relocalizer_ros
