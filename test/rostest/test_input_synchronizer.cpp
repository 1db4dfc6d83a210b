// The stamp checks in front of the node's synchronizer (issue 23): stamps that
// would abort the process never reach message_filters, one bad stamp costs
// one message, and a looping source is one jump. No master needed.

#include <gtest/gtest.h>
#include <ros/time.h>

#include <vector>

#include "../../src/ros/node/input_synchronizer.h"
#include "../../src/ros/node/stamp_gate.h"

using relocalizer_ros::InputSynchronizer;
using relocalizer_ros::StampGate;
using relocalizer_ros::stampNanoseconds;
using Drop = StampGate::Drop;

namespace {

constexpr int kColour = 0, kDepth = 1, kInfo = 2;

int64_t seconds(double s) { return static_cast<int64_t>(s * 1e9); }

// A gate on a clock the test moves.
struct Gate {
  StampGate gate;
  StampGate::Clock::time_point now{};
  StampGate::Decision in(int input, double stamp) { return at(input, seconds(stamp)); }
  StampGate::Decision at(int input, int64_t stamp_ns) {
    return gate.classify(input, stamp_ns, now);
  }
  // One frame of all three inputs, each admitted; 0.1 s of wall time passes.
  void frame(double stamp) {
    for (int input : {kColour, kDepth, kInfo}) {
      const auto d = in(input, stamp);
      EXPECT_TRUE(d.admit && !d.jump) << "input " << input << " at " << stamp;
    }
    now += std::chrono::milliseconds(100);
  }
};

struct Sets {
  std::vector<double> colour_stamps;
  int jumps = 0;
  std::vector<Drop> drops;
};

sensor_msgs::ImagePtr image(double stamp) {
  auto message = boost::make_shared<sensor_msgs::Image>();
  message->header.stamp.fromSec(stamp);
  return message;
}
sensor_msgs::CameraInfoPtr info(double stamp) {
  auto message = boost::make_shared<sensor_msgs::CameraInfo>();
  message->header.stamp.fromSec(stamp);
  return message;
}

InputSynchronizer makeSynchronizer(Sets& sets) {
  InputSynchronizer::Options options;
  options.max_interval = 0.05;
  InputSynchronizer::Events events;
  events.on_set = [&sets](const sensor_msgs::ImageConstPtr& colour,
                          const sensor_msgs::ImageConstPtr&,
                          const sensor_msgs::CameraInfoConstPtr&) {
    sets.colour_stamps.push_back(colour->header.stamp.toSec());
  };
  events.on_jump = [&sets](const StampGate::Jump&) { ++sets.jumps; };
  events.on_drop = [&sets](int, Drop why, int64_t) { sets.drops.push_back(why); };
  return InputSynchronizer(options, std::move(events));
}

class InputStamps : public testing::Test {
 protected:
  static void SetUpTestSuite() { ros::Time::init(); }  // message_filters stamps receipt times
};

}  // namespace

TEST(StampGate, StampsAreExactNanoseconds) {
  EXPECT_EQ(stampNanoseconds(4294967295u, 999999999u), 4294967295LL * 1000000000LL + 999999999LL);
  EXPECT_EQ(stampNanoseconds(0, 1), 1);
}

TEST(StampGate, AStampAtOrPast2038IsDroppedAndTheOthersGoOn) {
  Gate g;
  g.frame(1000.0);
  EXPECT_EQ(g.at(kInfo, stampNanoseconds(4294967295u, 0)).drop, Drop::BeyondRange);
  EXPECT_EQ(g.at(kColour, StampGate::kMaxStampNs).drop, Drop::BeyondRange);
  EXPECT_TRUE(g.at(kColour, StampGate::kMaxStampNs - 1).hold)
      << "just inside the range: off the timeline";
  g.frame(1000.1);
}

TEST(StampGate, ASmallStepBackIsJitterThatCostsOneMessage) {
  Gate g;
  for (int i = 0; i < 5; ++i) g.frame(100.0 + 0.1 * i);
  const auto late = g.in(kDepth, 100.4 - 0.03 - 0.1);
  EXPECT_EQ(late.drop, Drop::OutOfOrder);
  EXPECT_FALSE(late.jump);
  for (int i = 5; i < 10; ++i) g.frame(100.0 + 0.1 * i);
}

TEST(StampGate, ALoopingSourceIsOneJumpAndTheOldTimelinesLastMessagesAreDropped) {
  Gate g;
  for (int i = 0; i <= 10; ++i) g.frame(100.0 + 0.1 * i);
  // The bag starts again at 40 s. Colour first: held, not obeyed yet.
  const auto first = g.in(kColour, 40.0);
  EXPECT_TRUE(first.hold);
  EXPECT_FALSE(first.jump);
  // Depth and camera_info of the old timeline still arrive.
  EXPECT_TRUE(g.in(kDepth, 101.05).admit);
  // Depth follows: the jump is confirmed, from the newest old stamp to the held one.
  const auto second = g.in(kDepth, 40.0);
  ASSERT_TRUE(second.jump.has_value());
  EXPECT_EQ(second.jump->input, kColour);
  EXPECT_EQ(second.jump->from_ns, seconds(101.05));
  EXPECT_EQ(second.jump->to_ns, seconds(40.0));
  EXPECT_TRUE(second.admit);
  // camera_info has not followed: its old-timeline message is dropped, the next one moves it over.
  EXPECT_EQ(g.in(kInfo, 101.1).drop, Drop::OldTimeline);
  const auto follows = g.in(kInfo, 40.0);
  EXPECT_TRUE(follows.admit);
  EXPECT_FALSE(follows.jump) << "one loop is one jump";
  for (int i = 1; i <= 10; ++i) g.frame(40.0 + 0.1 * i);
}

TEST(StampGate, AJumpForwardIsConfirmedTooAndNeedsNoOtherInput) {
  Gate g;
  g.frame(100.0);
  g.frame(100.1);
  EXPECT_TRUE(g.in(kColour, 100.0 + 7200.0).hold);
  const auto confirmed = g.in(kColour, 100.1 + 7200.0);
  ASSERT_TRUE(confirmed.jump.has_value());
  EXPECT_GT(confirmed.jump->to_ns, confirmed.jump->from_ns);
  EXPECT_TRUE(confirmed.admit);
}

TEST(StampGate, AGlitchIsHeldThenDiscardedWithoutAJump) {
  Gate g;
  g.frame(500.0);
  EXPECT_TRUE(g.in(kDepth, 0.0).hold);                     // an unset stamp on one message
  for (int i = 1; i <= 20; ++i) g.frame(500.0 + 0.1 * i);  // 2 s: still held
  EXPECT_TRUE(g.gate.holding());
  g.now += StampGate::kWindow;
  const auto next = g.in(kColour, 503.0);
  EXPECT_TRUE(next.discard_held);
  EXPECT_TRUE(next.admit);
  EXPECT_FALSE(next.jump);
  EXPECT_FALSE(g.gate.holding());
}

TEST(StampGate, AnotherGlitchReplacesTheHeldOne) {
  Gate g;
  g.frame(500.0);
  EXPECT_TRUE(g.in(kDepth, 0.0).hold);
  const auto other = g.in(kInfo, 100000.0);  // far from both timelines
  EXPECT_TRUE(other.hold);
  EXPECT_TRUE(other.discard_held);
  EXPECT_FALSE(other.jump);
}

// The abort that a stamp far from the others caused (`Duration is out of dual
// 32-bit range`): message_filters alone throws on these stamps (colour 2.2e9 s
// ahead of depth and camera_info, as an uninitialised driver stamp can be)...
TEST_F(InputStamps, MessageFiltersAloneThrowsOnStampsFarApart) {
  using Policy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::Image,
                                                      sensor_msgs::CameraInfo>;
  message_filters::Synchronizer<Policy> sync{Policy(5)};
  const double now = 1.76e9;
  EXPECT_THROW(
      {
        sync.add<0>(sensor_msgs::ImageConstPtr(image(now + 2.2e9)));
        sync.add<1>(sensor_msgs::ImageConstPtr(image(now)));
        sync.add<2>(sensor_msgs::CameraInfoConstPtr(info(now)));
      },
      std::runtime_error);
}

// ...and never sees them behind the gate, which goes on pairing the good ones:
// whether the far stamp comes in the middle of a stream or first of all.
TEST_F(InputStamps, BehindTheGateStampsFarApartNeverReachIt) {
  for (const bool far_first : {false, true}) {
    SCOPED_TRACE(far_first ? "far stamp first" : "far stamp mid-stream");
    Sets sets;
    InputSynchronizer inputs = makeSynchronizer(sets);
    auto now = StampGate::Clock::now();
    const double start = 1.76e9;
    for (int i = 0; i < 20; ++i) {
      const double t = start + 0.1 * i;
      now += std::chrono::milliseconds(100);
      if (i == (far_first ? 0 : 10)) {
        ASSERT_NO_THROW(inputs.add<0>(sensor_msgs::ImageConstPtr(image(start + 2.2e9)), now));
        ASSERT_NO_THROW(inputs.add<0>(sensor_msgs::ImageConstPtr(image(2.1e9)), now));
      }
      ASSERT_NO_THROW(inputs.add<1>(sensor_msgs::ImageConstPtr(image(t)), now));
      ASSERT_NO_THROW(inputs.add<2>(sensor_msgs::CameraInfoConstPtr(info(t)), now));
      ASSERT_NO_THROW(inputs.add<0>(sensor_msgs::ImageConstPtr(image(t)), now));
    }
    EXPECT_GE(sets.colour_stamps.size(), 18u);
    // Mid-stream a glitch is no jump; as the very first stamp it defined the
    // timeline, and the next messages outvote it: one reset, nothing lost.
    EXPECT_EQ(sets.jumps, far_first ? 1 : 0);
    EXPECT_FALSE(sets.drops.empty());
    EXPECT_EQ(sets.drops.front(), Drop::BeyondRange);
  }
}

TEST_F(InputStamps, ALoopThroughTheSynchronizerIsOneResetAndSetsGoOn) {
  Sets sets;
  InputSynchronizer inputs = makeSynchronizer(sets);
  auto now = StampGate::Clock::now();
  auto frame = [&](double t) {
    now += std::chrono::milliseconds(100);
    inputs.add<0>(sensor_msgs::ImageConstPtr(image(t)), now);
    inputs.add<1>(sensor_msgs::ImageConstPtr(image(t)), now);
    inputs.add<2>(sensor_msgs::CameraInfoConstPtr(info(t)), now);
  };
  for (int i = 0; i < 20; ++i) frame(60.0 + 0.1 * i);
  const size_t before = sets.colour_stamps.size();
  for (int i = 0; i < 20; ++i) frame(0.1 * i);  // the bag starts over
  EXPECT_EQ(sets.jumps, 1);
  EXPECT_GE(sets.colour_stamps.size() - before, 17u)
      << "the new timeline's frames are synchronised";
  EXPECT_TRUE(sets.drops.empty());
}
