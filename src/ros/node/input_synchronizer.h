#pragma once
// The node's three inputs (colour, depth, camera_info) into synchronised sets.
// Every message passes the StampGate first: what it drops never reaches
// message_filters, what it holds waits here, and at a confirmed jump the
// synchronizer is replaced by an empty one (ApproximateTime keeps the sets it
// published as history and would hold the new timeline back behind the old).
//
// Not thread-safe: the caller serialises add(). The synchronizers are fed by
// hand, not connected to subscribers, so that one can be replaced while the
// subscribers' signals hold their own locks.

#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <boost/bind/bind.hpp>
#include <functional>
#include <memory>

#include "stamp_gate.h"

namespace relocalizer_ros {

class InputSynchronizer {
 public:
  using Clock = StampGate::Clock;
  struct Options {
    bool approximate = true;
    uint32_t queue_size = 5;
    double max_interval = 0.0;  // seconds; 0: no limit (ApproximateTime only)
  };
  struct Events {
    std::function<void(const sensor_msgs::ImageConstPtr&, const sensor_msgs::ImageConstPtr&,
                       const sensor_msgs::CameraInfoConstPtr&)>
        on_set;
    // Before the new timeline's first message reaches the new synchronizer.
    std::function<void(const StampGate::Jump&)> on_jump;
    // A message that never reaches the synchronizer, and why.
    std::function<void(int input, StampGate::Drop why, int64_t stamp_ns)> on_drop;
  };

  InputSynchronizer(Options options, Events events)
      : options_(options), events_(std::move(events)) {
    rebuild();
  }

  // `I`: 0 colour, 1 depth, 2 camera_info.
  template <int I, typename M>
  void add(const boost::shared_ptr<M const>& message, Clock::time_point now) {
    const int64_t stamp = stampNanoseconds(message->header.stamp.sec, message->header.stamp.nsec);
    const StampGate::Decision decision = gate_.classify(I, stamp, now);
    if (decision.discard_held) {
      held_ = nullptr;
      events_.on_drop(held_input_, StampGate::Drop::Unconfirmed, held_stamp_);
    }
    if (decision.jump) {
      events_.on_jump(*decision.jump);
      rebuild();
      if (held_) std::exchange(held_, nullptr)();
    }
    if (decision.admit) {
      feed<I>(message);
    } else if (decision.hold) {
      held_ = [this, message] { feed<I>(message); };
      held_input_ = I;
      held_stamp_ = stamp;
    } else if (decision.drop != StampGate::Drop::None) {
      events_.on_drop(I, decision.drop, stamp);
    }
  }

 private:
  using ApproximatePolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image,
                                                      sensor_msgs::CameraInfo>;
  using ExactPolicy =
      message_filters::sync_policies::ExactTime<sensor_msgs::Image, sensor_msgs::Image,
                                                sensor_msgs::CameraInfo>;

  void rebuild() {
    const auto forward = boost::bind(&InputSynchronizer::forward, this, boost::placeholders::_1,
                                     boost::placeholders::_2, boost::placeholders::_3);
    approximate_.reset();
    exact_.reset();
    if (options_.approximate) {
      approximate_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
          ApproximatePolicy(options_.queue_size));
      if (options_.max_interval > 0.0)
        approximate_->setMaxIntervalDuration(ros::Duration(options_.max_interval));
      approximate_->registerCallback(forward);
    } else {
      exact_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
          ExactPolicy(options_.queue_size));
      exact_->registerCallback(forward);
    }
  }

  void forward(const sensor_msgs::ImageConstPtr& colour, const sensor_msgs::ImageConstPtr& depth,
               const sensor_msgs::CameraInfoConstPtr& info) {
    events_.on_set(colour, depth, info);
  }

  template <int I, typename M>
  void feed(const boost::shared_ptr<M const>& message) {
    if (approximate_)
      approximate_->template add<I>(message);
    else
      exact_->template add<I>(message);
  }

  const Options options_;
  const Events events_;
  StampGate gate_;
  std::function<void()> held_;
  int held_input_ = 0;
  int64_t held_stamp_ = 0;
  std::unique_ptr<message_filters::Synchronizer<ApproximatePolicy>> approximate_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_;
};

}  // namespace relocalizer_ros
