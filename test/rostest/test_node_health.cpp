// The rules /diagnostics judges the node by (node_health.h), state by state,
// without a master.

#include <gtest/gtest.h>

#include "../../src/ros/node/node_health.h"

using relocalizer_ros::HealthLevel;
using relocalizer_ros::HealthLimits;
using relocalizer_ros::judgeHealth;
using relocalizer_ros::NodeHealth;

namespace {

constexpr HealthLimits kLimits{3.0, 10};

// A node that answers: a place, frames flowing, the last pose a moment ago.
NodeHealth answering() {
  NodeHealth health;
  health.usable = true;
  health.any_frame = true;
  health.since_frame = 0.1;
  health.since_pose = 0.5;
  return health;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST(NodeHealth, AnsweringIsOkWithTheAgeOfTheLastPose) {
  const auto verdict = judgeHealth(answering(), kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Ok);
  EXPECT_EQ(verdict.message, "last pose 0.50 s ago");
  NodeHealth waiting = answering();
  waiting.since_pose = -1.0;  // on demand, no call yet
  EXPECT_EQ(judgeHealth(waiting, kLimits).level, HealthLevel::Ok);
  EXPECT_EQ(judgeHealth(waiting, kLimits).message, "ready, no pose yet");
}

TEST(NodeHealth, NoUsablePlaceIsAnErrorWhateverElseHolds) {
  NodeHealth health = answering();
  health.usable = false;
  health.unusable_reason = "no model yet: learning has 1 key frames";
  health.since_frame = 100.0;     // stopped inputs too
  health.failures_in_a_row = 50;  // and failures
  const auto verdict = judgeHealth(health, kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Error);
  EXPECT_EQ(verdict.message, "no usable place: no model yet: learning has 1 key frames");
}

TEST(NodeHealth, InputsThatStopWarnAtTheTimeoutAndNotBefore) {
  NodeHealth health = answering();
  health.since_frame = 2.99;
  EXPECT_EQ(judgeHealth(health, kLimits).level, HealthLevel::Ok);
  health.since_frame = 3.0;
  auto verdict = judgeHealth(health, kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Warn);
  EXPECT_EQ(verdict.message, "inputs stopped: no camera frame for 3.00 s (input_timeout 3.00 s)");
  health.any_frame = false;
  health.since_pose = -1.0;
  verdict = judgeHealth(health, kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Warn);
  EXPECT_TRUE(contains(verdict.message, "no camera frame since start")) << verdict.message;
  // input_timeout 0 turns the rule off, as it turns the watchdog off.
  EXPECT_EQ(judgeHealth(health, HealthLimits{0.0, 10}).level, HealthLevel::Ok);
}

TEST(NodeHealth, FailuresInARowWarnWithTheLastReason) {
  NodeHealth health = answering();
  health.failures_in_a_row = 9;
  health.last_failure = "weak evidence: 12 point inliers (at least 30)";
  EXPECT_EQ(judgeHealth(health, kLimits).level, HealthLevel::Ok);
  health.failures_in_a_row = 10;
  const auto verdict = judgeHealth(health, kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Warn);
  EXPECT_EQ(verdict.message,
            "10 frames in a row without a pose: weak evidence: 12 point inliers (at least 30)");
  EXPECT_EQ(judgeHealth(health, HealthLimits{3.0, 0}).level, HealthLevel::Ok);  // 0: never
}

TEST(NodeHealth, StoppedInputsAreNamedBeforeTheFailuresTheyCause) {
  NodeHealth health = answering();
  health.failures_in_a_row = 20;
  health.last_failure = "no frame within 2.00 s";
  health.since_frame = 5.0;
  const auto verdict = judgeHealth(health, kLimits);
  EXPECT_EQ(verdict.level, HealthLevel::Warn);
  EXPECT_TRUE(contains(verdict.message, "inputs stopped")) << verdict.message;
}
