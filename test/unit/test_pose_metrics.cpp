#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/eval/evaluation.h"
#include "relocalizer/eval/metrics.h"
#include "support.h"

using namespace relocalizer;

namespace {
Pose makePose(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Pose p = Pose::Identity();
  p.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}
}  // namespace

TEST(PoseErrors, TenDegreeRotationReadsAsTen) {
  const Pose truth = makePose(30, {0.2, 1, 0.1}, {1, 2, 3});
  const Pose estimate = truth * makePose(10, {1, -0.5, 0.3}, Eigen::Vector3d::Zero());
  EXPECT_NEAR(rotationErrorDegrees(estimate, truth), 10.0, 1e-9);
  EXPECT_NEAR(translationError(estimate, truth), 0.0, 1e-12);
}

TEST(PoseErrors, TranslationErrorIsCentreDistance) {
  const Pose truth = makePose(0, {0, 0, 1}, {0, 0, 0});
  const Pose estimate = makePose(0, {0, 0, 1}, {0.03, 0.04, 0});
  EXPECT_NEAR(translationError(estimate, truth), 0.05, 1e-12);
}

TEST(PoseErrors, SmallAnglesAreAccurate) {
  const Pose truth = makePose(45, {1, 1, 0}, {0, 0, 0});
  const Pose estimate = truth * makePose(0.01, {0, 0, 1}, Eigen::Vector3d::Zero());
  EXPECT_NEAR(rotationErrorDegrees(estimate, truth), 0.01, 1e-9);
}

TEST(PoseErrors, NonOrthonormalGroundTruthIsProjectedFirst) {
  // Column norms of 0.9999, as in KinectFusion ground truth: a perfect estimate
  // must read as (nearly) zero, not the ~0.8 degrees of the raw trace formula.
  const Pose exact = makePose(20, {0.3, 0.4, 1}, {0.5, 0.1, 0.2});
  Eigen::Matrix4d shrunk = exact.matrix();
  shrunk.topLeftCorner<3, 3>() *= 0.9999;
  const double raw_trace_angle =
      std::acos(std::clamp(
          (shrunk.topLeftCorner<3, 3>().transpose() * exact.linear()).trace() / 2.0 - 0.5, -1.0,
          1.0)) *
      180 / M_PI;
  EXPECT_GT(raw_trace_angle, 0.5);
  auto parsed = poseFromMatrix(shrunk);
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  EXPECT_LT(rotationErrorDegrees(*parsed, exact), 1e-6);
}

TEST(PoseFromMatrix, RejectsNaNAndBadLastRow) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 3) = std::nan("");
  EXPECT_FALSE(poseFromMatrix(m).ok());
  EXPECT_NE(poseFromMatrix(m).error().find("NaN"), std::string::npos);
  m = Eigen::Matrix4d::Identity();
  m(3, 0) = 1;
  EXPECT_FALSE(poseFromMatrix(m).ok());
  m = Eigen::Matrix4d::Identity() * 2;
  m(3, 3) = 1;
  EXPECT_FALSE(poseFromMatrix(m).ok());
}

TEST(Horn, RecoversKnownRigidTransform) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  const Pose known = makePose(37, {0.1, -0.7, 0.4}, {0.3, -1.2, 2.5});
  std::vector<Eigen::Vector3d> source, target;
  for (int i = 0; i < 50; ++i) {
    Eigen::Vector3d p(u(rng), u(rng), u(rng));
    source.push_back(p);
    target.push_back(known * p);
  }
  const Pose found = hornAlignment(source, target);
  EXPECT_LT((found.matrix() - known.matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Metrics, SharesMediansAndAteAgainstHandComputedValues) {
  const Pose truth = Pose::Identity();
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  // Four frames: 1 cm / 1 deg, 3 cm / 1 deg, 10 cm / 0 deg, no pose.
  const std::vector<std::optional<Pose>> cases = {
      makePose(1, {0, 0, 1}, {0.01, 0, 0}), makePose(1, {0, 1, 0}, {0, 0.03, 0}),
      makePose(0, {0, 0, 1}, {0, 0, 0.10}), std::nullopt};
  for (size_t i = 0; i < cases.size(); ++i) {
    errors.push_back(frameError(static_cast<int>(i), cases[i], truth));
    estimates.push_back(cases[i]);
    truths.push_back(truth);
  }
  const AccuracySummary s = summarizeAccuracy(errors, estimates, truths);
  EXPECT_EQ(s.frames, 4);
  EXPECT_EQ(s.frames_with_pose, 3);
  EXPECT_DOUBLE_EQ(s.within_5cm_5deg, 0.5);
  EXPECT_DOUBLE_EQ(s.within_2cm_2deg, 0.25);
  EXPECT_EQ(s.wrong_answers, 0);  // 10 cm is the last right answer; no pose is never wrong
  // Sorted translations: 0.01, 0.03, 0.10, inf -> median (0.03 + 0.10) / 2.
  EXPECT_NEAR(s.median_translation_m, 0.065, 1e-12);
  EXPECT_NEAR(s.median_rotation_deg, 1.0, 1e-9);
  EXPECT_TRUE(std::isfinite(s.ate_rmse_m));
  EXPECT_GE(s.ate_rmse_m, 0.0);
}

TEST(Metrics, WrongAnswersAreThoseBeyondTenCentimetresOrTenDegrees) {
  const Pose truth = makePose(0, {0, 0, 1}, {0, 0, 0});
  const std::vector<std::optional<Pose>> cases = {
      makePose(0, {0, 0, 1}, {0.10, 0, 0}),   // 10 cm: imprecise, not wrong
      makePose(0, {0, 0, 1}, {0.101, 0, 0}),  // wrong by translation
      makePose(10.5, {0, 1, 0}, {0, 0, 0}),   // wrong by rotation
      makePose(9.5, {0, 1, 0}, {0, 0, 0.09}), std::nullopt};
  std::vector<FrameError> errors;
  for (size_t i = 0; i < cases.size(); ++i)
    errors.push_back(frameError(static_cast<int>(i), cases[i], truth));
  EXPECT_FALSE(wrongAnswer(errors[0]));
  EXPECT_TRUE(wrongAnswer(errors[1]));
  EXPECT_TRUE(wrongAnswer(errors[2]));
  EXPECT_FALSE(wrongAnswer(errors[3]));
  EXPECT_FALSE(wrongAnswer(errors[4]));
  EXPECT_EQ(summarizeAccuracy(errors, cases, std::vector<Pose>(cases.size(), truth)).wrong_answers,
            2);
}

TEST(Metrics, CorrectIsInclusiveAndNeedsAPose) {
  FrameError e;
  e.has_pose = true;
  e.translation_m = kCorrectPose.metres;
  e.rotation_deg = kCorrectPose.degrees;
  EXPECT_TRUE(within(e, kCorrectPose));  // the boundary counts, as the literature's tables do
  EXPECT_FALSE(within(e, kFinePose));
  e.rotation_deg = std::nextafter(kCorrectPose.degrees, 10.0);
  EXPECT_FALSE(within(e, kCorrectPose));
  e = frameError(0, std::nullopt, Pose::Identity());
  EXPECT_FALSE(within(e, {1e9, 1e9}));
}

TEST(Evaluation, RecordsOfAttemptsSummarizeAsTheirErrors) {
  Relocalization answered;
  answered.success = true;
  answered.pose = makePose(1, {0, 0, 1}, {0.01, 0, 0});
  answered.timings.total = 0.010;
  Relocalization refused;
  refused.message = "too few inliers";
  refused.timings.total = 0.030;
  const std::vector<EvaluationRecord> records = {recordAttempt(4, 0.4, Pose::Identity(), answered),
                                                 recordAttempt(5, 0.5, Pose::Identity(), refused)};
  EXPECT_EQ(records[0].id, 4);
  EXPECT_TRUE(records[0].estimate.has_value());
  EXPECT_FALSE(records[1].estimate.has_value());
  EXPECT_EQ(records[1].message, "too few inliers");
  const EvaluationSummary s = summarizeEvaluation(records);
  EXPECT_DOUBLE_EQ(s.accuracy.within_5cm_5deg, 0.5);
  EXPECT_DOUBLE_EQ(s.total.median_ms, 20.0);
  EXPECT_DOUBLE_EQ(s.total.p95_ms,
                   stageLatency({answered.timings, refused.timings}, &StageTimings::total).p95_ms);
  EXPECT_NEAR(s.total.p95_ms, 29.0, 1e-9);
}

TEST(Metrics, AteIsZeroForRigidlyMovedTrajectory) {
  const Pose offset = makePose(15, {0, 0, 1}, {1, 2, 0});
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (int i = 0; i < 10; ++i) {
    const Pose t = makePose(i * 3, {0, 1, 0}, {0.1 * i, std::sin(i), 0.05 * i * i});
    truths.push_back(t);
    estimates.push_back(offset * t);
    errors.push_back(frameError(i, estimates.back(), t));
  }
  EXPECT_NEAR(summarizeAccuracy(errors, estimates, truths).ate_rmse_m, 0.0, 1e-9);
}

TEST(Percentile, InterpolatesLinearly) {
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 50), 3);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 50), 2.5);
  EXPECT_DOUBLE_EQ(percentile({10, 0}, 95), 9.5);
  EXPECT_TRUE(std::isnan(median({})));
}

TEST(Depth, MillimetresToMetresWithInvalidMarkers) {
  cv::Mat raw(1, 4, CV_16UC1);
  raw.at<uint16_t>(0, 0) = 0;
  raw.at<uint16_t>(0, 1) = 1500;
  raw.at<uint16_t>(0, 2) = 65535;
  raw.at<uint16_t>(0, 3) = 5000;
  auto metres = depthToMetres(raw, 1000.0);
  ASSERT_TRUE(metres.ok());
  EXPECT_TRUE(std::isnan(metres->at<float>(0, 0)));
  EXPECT_FLOAT_EQ(metres->at<float>(0, 1), 1.5f);
  EXPECT_TRUE(std::isnan(metres->at<float>(0, 2)));
  EXPECT_FLOAT_EQ(metres->at<float>(0, 3), 5.0f);
  EXPECT_EQ(countValidDepth(*metres), 2);
  auto tum = depthToMetres(raw, 5000.0);
  EXPECT_FLOAT_EQ(tum->at<float>(0, 3), 1.0f);
}

TEST(Depth, FloatMetresDropNonPositiveAndNonFinite) {
  cv::Mat raw =
      (cv::Mat_<float>(1, 4) << 1.25f, -1.0f, std::numeric_limits<float>::infinity(), 0.0f);
  auto metres = depthToMetres(raw);
  ASSERT_TRUE(metres.ok());
  EXPECT_FLOAT_EQ(metres->at<float>(0, 0), 1.25f);
  EXPECT_EQ(countValidDepth(*metres), 1);
}

TEST(Depth, RejectsColourImages) {
  cv::Mat colour(2, 2, CV_8UC3, cv::Scalar(1, 2, 3));
  auto metres = depthToMetres(colour);
  ASSERT_FALSE(metres.ok());
  EXPECT_NE(metres.error().find("16-bit"), std::string::npos);
}

TEST(Frame, ValidationNamesTheMismatch) {
  RgbdFrame f;
  f.colour = cv::Mat(480, 640, CV_8UC3);
  f.depth = cv::Mat(240, 320, CV_32FC1);
  EXPECT_NE(frameValidationError(f).find("differ in size"), std::string::npos);
  f.depth = cv::Mat(480, 640, CV_32FC1);
  EXPECT_EQ(frameValidationError(f), "");
  f.camera.fx = 0;
  EXPECT_NE(frameValidationError(f).find("focal"), std::string::npos);
  f.camera.fx = 585;
  f.camera.width = 320;
  EXPECT_NE(frameValidationError(f).find("intrinsics are for"), std::string::npos);
}
