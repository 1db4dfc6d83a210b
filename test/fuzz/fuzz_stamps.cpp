// The node's input stamp handling (src/ros/node/stamp_gate.h, input_synchronizer.h)
// on arbitrary stamps, in front of the real message_filters synchronizers, as
// the node feeds them: any exception (ros::Duration's "out of dual 32-bit
// range" aborted the node, issue 23) or broken promise is a crash.
//
// Input: one configuration byte (policy, queue size, max_interval), then
// records of 10 bytes: input and stamp kind, wall-time step, 8 bytes of stamp.

#include <ros/console.h>
#include <ros/time.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "input_synchronizer.h"

using relocalizer_ros::InputSynchronizer;
using relocalizer_ros::StampGate;

namespace {

ros::Time fromNanoseconds(int64_t ns) {
  ros::Time t;
  t.sec = static_cast<uint32_t>(static_cast<uint64_t>(ns) / 1000000000u);
  t.nsec = static_cast<uint32_t>(static_cast<uint64_t>(ns) % 1000000000u);
  return t;
}

int64_t toNanoseconds(const ros::Time& t) {
  return relocalizer_ros::stampNanoseconds(t.sec, t.nsec);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  ros::Time::init();  // message_filters stamps each message's receipt time
  // message_filters warns once per synchronizer, and the fuzzer rebuilds many.
  if (ros::console::set_logger_level(ROSCONSOLE_DEFAULT_NAME, ros::console::levels::Fatal))
    ros::console::notifyLoggerLevelsChanged();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t config = data[0];
  InputSynchronizer::Options options;
  options.approximate = (config & 1) == 0;
  options.queue_size = 1 + ((config >> 1) & 7);
  // The node's parameter bounds max_interval to [0, 3600] s.
  const double intervals[4] = {0.0, 0.05, 1.0, 3600.0};
  options.max_interval = intervals[(config >> 4) & 3];

  bool in_range = true;
  bool in_interval = true;
  int64_t last_set_ns = -1;
  InputSynchronizer::Events events;
  events.on_set = [&](const sensor_msgs::ImageConstPtr& colour,
                      const sensor_msgs::ImageConstPtr& depth,
                      const sensor_msgs::CameraInfoConstPtr& info) {
    const int64_t stamps[3] = {toNanoseconds(colour->header.stamp),
                               toNanoseconds(depth->header.stamp),
                               toNanoseconds(info->header.stamp)};
    int64_t low = stamps[0], high = stamps[0];
    for (int64_t s : stamps) {
      in_range &= s >= 0 && s < StampGate::kMaxStampNs;
      low = std::min(low, s);
      high = std::max(high, s);
    }
    if (!options.approximate)
      in_interval &= low == high;
    else if (options.max_interval > 0.0)
      in_interval &= high - low <= static_cast<int64_t>(options.max_interval * 1e9) + 1;
    last_set_ns = high;
  };
  events.on_jump = [](const StampGate::Jump& jump) {
    if (jump.to_ns < 0 || jump.to_ns >= StampGate::kMaxStampNs) std::abort();
  };
  events.on_drop = [](int input, StampGate::Drop why, int64_t) {
    if (input < 0 || input > 2 || why == StampGate::Drop::None) std::abort();
  };
  InputSynchronizer inputs(options, std::move(events));

  // Wall time starts where any stamp might: the gate must not care.
  StampGate::Clock::time_point now{};
  int64_t previous[3] = {1'700'000'000'000'000'000LL, 1'700'000'000'000'000'000LL,
                         1'700'000'000'000'000'000LL};
  for (size_t at = 1; at + 10 <= size; at += 10) {
    const uint8_t kind = data[at];
    const int input = kind % 3;
    now += std::chrono::milliseconds(10 * data[at + 1]);
    uint64_t raw;
    std::memcpy(&raw, data + at + 2, sizeof(raw));
    int64_t stamp_ns;
    switch ((kind / 3) % 4) {
      case 0:  // a step from this input's previous stamp, up to +-2^31 ms
        stamp_ns = previous[input] + static_cast<int64_t>(static_cast<int32_t>(raw)) * 1'000'000;
        break;
      case 1:  // a small step (ms), as real streams make
        stamp_ns = previous[input] + static_cast<int64_t>(static_cast<int16_t>(raw)) * 1'000'000;
        break;
      case 2:  // another input's previous stamp, slightly moved
        stamp_ns = previous[(input + 1 + (raw & 1)) % 3] +
                   static_cast<int64_t>(static_cast<int8_t>(raw >> 8)) * 1'000'000;
        break;
      default:  // anything a uint32 sec / nsec can hold
        stamp_ns = relocalizer_ros::stampNanoseconds(
            static_cast<uint32_t>(raw), static_cast<uint32_t>(raw >> 32) % 1000000000u);
        break;
    }
    const int64_t max_ns = relocalizer_ros::stampNanoseconds(4294967295u, 999999999u);
    if (stamp_ns < 0) stamp_ns = 0;
    if (stamp_ns > max_ns) stamp_ns = max_ns;
    previous[input] = stamp_ns;
    const ros::Time stamp = fromNanoseconds(stamp_ns);
    if (input == 2) {
      auto message = boost::make_shared<sensor_msgs::CameraInfo>();
      message->header.stamp = stamp;
      inputs.add<2>(sensor_msgs::CameraInfoConstPtr(message), now);
    } else {
      auto message = boost::make_shared<sensor_msgs::Image>();
      message->header.stamp = stamp;
      if (input == 0)
        inputs.add<0>(sensor_msgs::ImageConstPtr(message), now);
      else
        inputs.add<1>(sensor_msgs::ImageConstPtr(message), now);
    }
    // Sets only ever hold stamps the node can do arithmetic on, and only
    // stamps as close as the policy promises.
    if (!in_range || !in_interval) std::abort();
  }
  return 0;
}
