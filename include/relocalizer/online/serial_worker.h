#pragma once
// A thread that runs the jobs handed to it one at a time, in order: the
// submap learner's freezes (each a last retrain, seconds) and the stopping of
// the learners it hands over (each joins a worker), both off the learning
// thread. A job is run and destroyed on the worker's thread, so what it
// holds is released there too.

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

namespace relocalizer {

class SerialWorker {
 public:
  SerialWorker();
  // Runs every job posted before, then joins.
  ~SerialWorker();
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  void post(std::function<void()> job);

 private:
  void loop();

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::thread thread_;  // last: starts after the rest is built
};

}  // namespace relocalizer
