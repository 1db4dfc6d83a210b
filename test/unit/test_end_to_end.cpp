// The whole method on a generated room with exact ground truth: forests trained
// on one camera path, relocalization of frames from another.

#include <gtest/gtest.h>

#include <stdexcept>

#include "relocalizer/core/photometric_change.h"
#include "relocalizer/core/statistics.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/relocalize/relocalizer.h"
#include "relocalizer/relocalize/second_draw.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "relocalizer/surface/surface_model.h"

using namespace relocalizer;

namespace {

// The room, the camera and the paths every test here shares.
const SyntheticRoom& room() {
  static const SyntheticRoom kRoom(7);
  return kRoom;
}
CameraIntrinsics smallCamera() { return CameraIntrinsics::kinectDefault().scaledTo(320, 240); }
constexpr int kTrainFrames = 80, kTestFrames = 30;

// Forests of the room's training frames grown to CI's size under `params`'
// colour choices.
Model trainedOnRoom(TrainingParams params) {
  for (ForestParams* f : {&params.points, &params.lines}) {
    f->trees = 3;
    f->max_depth = 16;
    f->samples_per_image = 1000;
  }
  const SyntheticTrajectories paths = room().trajectories(kTrainFrames, kTestFrames);
  ModelBuilder builder(params);
  for (size_t i = 0; i < paths.train.size(); ++i)
    builder.add(room().render(paths.train[i], smallCamera(), static_cast<int>(i)));
  auto built = builder.build({});
  if (!built.ok()) throw std::runtime_error(built.error());
  return std::move(*built);
}

RelocalizerParams smallRelocalization() {
  RelocalizerParams reloc;
  reloc.point_samples = 1000;
  reloc.line_samples = 500;
  reloc.solver.hypotheses = 256;
  return reloc;
}

// How `relocalizer` does on `frames` seen under `light`.
AccuracySummary accuracyUnder(const Relocalizer& relocalizer, const std::vector<RgbdFrame>& frames,
                              const PhotometricChange& light) {
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (const RgbdFrame& recorded : frames) {
    RgbdFrame frame = recorded;
    frame.colour = applyPhotometricChange(recorded.colour, light);
    const Relocalization r = relocalizer.relocalize(frame);
    estimates.push_back(r.success ? std::optional<Pose>(r.pose) : std::nullopt);
    errors.push_back(frameError(frame.id, estimates.back(), *frame.ground_truth));
    truths.push_back(*frame.ground_truth);
  }
  return summarizeAccuracy(errors, estimates, truths);
}

PhotometricChange evening() {
  PhotometricChange light;
  light.stops = -1;
  light.kelvin = 2700;
  return light;
}

// The rule of second_draw.h on answers made up for it.
Relocalization answerAt(const Eigen::Vector3d& position, float score) {
  Relocalization answer;
  answer.success = true;
  answer.pose.translation() = position;
  answer.score = score;
  answer.timings.total = 0.010;
  return answer;
}

}  // namespace

TEST(SecondDraw, OnlyWeakAnswersAreDrawnAgain) {
  EXPECT_TRUE(needsSecondDraw(answerAt({0, 0, 0}, 0.17f), 0.25f));
  EXPECT_FALSE(needsSecondDraw(answerAt({0, 0, 0}, 0.30f), 0.25f));
  EXPECT_FALSE(needsSecondDraw(answerAt({0, 0, 0}, 0.17f), 0.0f));  // never asked
  Relocalization no_pose = answerAt({0, 0, 0}, 0.05f);
  no_pose.success = false;
  EXPECT_FALSE(needsSecondDraw(no_pose, 0.25f));
}

TEST(SecondDraw, AnAgreeingDrawConfirmsAndADisagreeingOrFailedOneRefuses) {
  const Relocalization first = answerAt({1.0, 2.0, 0.5}, 0.17f);
  const Relocalization agrees =
      confirmedBySecondDraw(first, answerAt({1.03, 2.0, 0.5}, 0.2f), 0.25f);
  EXPECT_TRUE(agrees.success);
  EXPECT_TRUE(agrees.second_draw);
  EXPECT_TRUE(agrees.pose.isApprox(first.pose));    // the first answer, confirmed
  EXPECT_NEAR(agrees.timings.total, 0.020, 1e-12);  // both draws are the answer's time

  const Relocalization apart =
      confirmedBySecondDraw(first, answerAt({1.42, 2.0, 0.5}, 0.2f), 0.25f);
  EXPECT_FALSE(apart.success);
  EXPECT_TRUE(apart.second_draw);
  EXPECT_NE(apart.message.find("not confirmed: 17.0% of the samples are inliers (below 25.0%"),
            std::string::npos)
      << apart.message;
  EXPECT_NE(apart.message.find("answered 0.42 m and 0.0 deg away"), std::string::npos)
      << apart.message;

  Relocalization turned = answerAt({1.0, 2.0, 0.5}, 0.2f);
  turned.pose.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_FALSE(confirmedBySecondDraw(first, turned, 0.25f).success);  // 11.5 deg

  Relocalization none = answerAt({1.0, 2.0, 0.5}, 0.02f);
  none.success = false;
  none.message = "weak evidence: 15 inliers";
  const Relocalization unconfirmed = confirmedBySecondDraw(first, none, 0.25f);
  EXPECT_FALSE(unconfirmed.success);
  EXPECT_NE(unconfirmed.message.find("found no pose: weak evidence: 15 inliers"), std::string::npos)
      << unconfirmed.message;
}

namespace {

// Small enough for CI (about half a minute on 2 cores), large enough to be a
// real relocalization problem: 320x240, 80 training frames along one loop,
// 30 test frames along another.
class SyntheticRoomRelocalization : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const SyntheticTrajectories paths = room().trajectories(kTrainFrames, kTestFrames);
    for (size_t i = 0; i < paths.test.size(); ++i)
      test_frames_.push_back(
          room().render(paths.test[i], smallCamera(), static_cast<int>(kTrainFrames + i)));
    TrainingParams params;
    params.colour_normalisation = ColourNormalisation::kChannelStatistics;
    Model model = trainedOnRoom(params);
    const RelocalizerParams reloc = smallRelocalization();
    RelocalizerParams unchecked = reloc;
    unchecked.surface.enabled = false;
    without_surface_ = new Relocalizer(model, unchecked);
    relocalizer_ = new Relocalizer(std::move(model), reloc);
  }
  static void TearDownTestSuite() {
    delete relocalizer_;
    relocalizer_ = nullptr;
    delete without_surface_;
    without_surface_ = nullptr;
    test_frames_.clear();
  }
  static Relocalizer* relocalizer_;
  static Relocalizer* without_surface_;  // the same model, answering with the solver's pose
  static std::vector<RgbdFrame> test_frames_;
};

Relocalizer* SyntheticRoomRelocalization::relocalizer_ = nullptr;
Relocalizer* SyntheticRoomRelocalization::without_surface_ = nullptr;
std::vector<RgbdFrame> SyntheticRoomRelocalization::test_frames_;

}  // namespace

// Threshold 25% per forest: RANSAC draws three correspondences per hypothesis,
// so an inlier share w gives all-inlier hypotheses with probability w^3; at
// 25% about 4 of 256 hypotheses are clean, enough for preemptive RANSAC to
// find one. A forest that learnt nothing would land within 10 cm of the truth
// in under 0.1% of samples (the room holds ~85 m^3). We measured 33% (points)
// and 51% (lines) at this scale.
TEST_F(SyntheticRoomRelocalization, ForestPredictionsLandNearTheTruthOnHeldOutFrames) {
  for (bool lines : {false, true}) {
    long samples = 0, within = 0, any = 0;
    for (const RgbdFrame& frame : test_frames_) {
      auto q = relocalizer_->measurePredictions(frame, lines, 0.10f);
      ASSERT_TRUE(q.ok()) << q.error();
      samples += q->samples;
      within += q->chosen_within;
      any += q->any_within;
    }
    ASSERT_GT(samples, 1000);
    const double share = static_cast<double>(within) / samples;
    EXPECT_GT(share, 0.25) << (lines ? "line" : "point") << " forest";
    EXPECT_GE(any, within);  // some candidate is at least as good as the chosen one
    std::printf("%s forest: %.1f%% of %ld predictions within 10 cm (%.1f%% with some candidate)\n",
                lines ? "line" : "point", 100.0 * share, samples, 100.0 * any / samples);
  }
}

TEST_F(SyntheticRoomRelocalization, NinetyPercentOfTestFramesWithinFiveCentimetresFiveDegrees) {
  std::vector<FrameError> errors;
  std::vector<std::optional<Pose>> estimates;
  std::vector<Pose> truths;
  for (const RgbdFrame& frame : test_frames_) {
    const Relocalization r = relocalizer_->relocalize(frame);
    std::optional<Pose> estimate;
    if (r.success) estimate = r.pose;
    errors.push_back(frameError(frame.id, estimate, *frame.ground_truth));
    estimates.push_back(estimate);
    truths.push_back(*frame.ground_truth);
    if (r.success) {
      EXPECT_GT(r.point_inliers, 0);
      EXPECT_GT(r.covariance.diagonal().minCoeff(), 0.0);
      EXPECT_GT(r.timings.total, 0.0);
    }
  }
  const AccuracySummary s = summarizeAccuracy(errors, estimates, truths);
  std::printf("synthetic room: %.1f%% within 5 cm / 5 deg, median %.2f cm / %.2f deg\n",
              100 * s.within_5cm_5deg, 100 * s.median_translation_m, s.median_rotation_deg);
  EXPECT_GE(s.within_5cm_5deg, 0.90);
  EXPECT_LT(s.median_translation_m, 0.02);
}

// Evening: half the light, from a tungsten lamp (2700 K) instead of the light
// the room was trained in. The colour statistics the fixture's model sees
// through (colour_normalisation.h) cancel the gain and the cast, so the frames
// are found as in the training light: 100 % here, against 50 % (the rest "no
// pose") with the fixture's model trained with colour_normalisation none.
TEST_F(SyntheticRoomRelocalization, EveningLightIsFoundAsInTheLightOfTraining) {
  const AccuracySummary s = accuracyUnder(*relocalizer_, test_frames_, evening());
  std::printf("synthetic room, evening light: %.1f%% within 5 cm / 5 deg, %d wrong\n",
              100 * s.within_5cm_5deg, s.wrong_answers);
  EXPECT_GE(s.within_5cm_5deg, 0.90);
  EXPECT_EQ(s.wrong_answers, 0);
}

// The other way to the same end (light_augmentation.h): the room trained on
// its recorded frames each seen under a light drawn at random, relocalized in
// the evening from the frames' recorded colour. Trained without it, the same
// model found a third of these frames (33 %, the rest "no pose"); with it,
// 100 % on Debian 12 and 13 and 86.7 % on Debian 11 (other libraries, other
// forests), so the bar is 80 %.
TEST_F(SyntheticRoomRelocalization, TrainedUnderDrawnLightsEveningIsFoundFromTheRecordedColour) {
  TrainingParams params;
  params.light_augmentation.max_stops = 1.0;
  params.light_augmentation.min_kelvin = 2500.0;
  params.light_augmentation.max_kelvin = 8500.0;
  const Relocalizer augmented(trainedOnRoom(params), smallRelocalization());
  const AccuracySummary s = accuracyUnder(augmented, test_frames_, evening());
  std::printf(
      "synthetic room trained under drawn lights, evening: %.1f%% within 5 cm / 5 deg, "
      "%d wrong\n",
      100 * s.within_5cm_5deg, s.wrong_answers);
  EXPECT_GE(s.within_5cm_5deg, 0.80);
  EXPECT_EQ(s.wrong_answers, 0);
}

// The recorded colour's own way back (light_retry.h): a model trained on the
// frames as recorded, asked about the evening or a dim room, answers in the
// frames' own light only some of them; each frame it cannot answer is asked
// again rebalanced into the training light, found by the training view it
// resembles. Frames in the light of training are never asked twice.
TEST_F(SyntheticRoomRelocalization, RecordedColourFindsTheEveningByAskingAgainInTheTrainingLight) {
  Model model = trainedOnRoom(TrainingParams{});
  ASSERT_GT(model.summary.light_chromaticity.minCoeff(), 0.0f);
  RelocalizerParams once = smallRelocalization();
  once.light_retry_min_cast = 0.0f;
  const Relocalizer own_colour(model, once);
  const Relocalizer retrying(std::move(model), smallRelocalization());
  const AccuracySummary alone = accuracyUnder(own_colour, test_frames_, evening());
  const AccuracySummary asked_again = accuracyUnder(retrying, test_frames_, evening());
  int retried = 0;
  for (const RgbdFrame& recorded : test_frames_) {
    RgbdFrame frame = recorded;
    frame.colour = applyPhotometricChange(recorded.colour, evening());
    const Relocalization evening_answer = retrying.relocalize(frame);
    if (evening_answer.light_cast > 0.0f) {
      ++retried;
      EXPECT_GE(evening_answer.light_cast, retrying.params().light_retry_min_cast);
    }
    EXPECT_EQ(retrying.relocalize(recorded).light_cast, 0.0f) << "frame " << recorded.id;
  }
  std::printf(
      "synthetic room trained in the recorded colour, evening: %.1f%% in the frames' colour, "
      "%.1f%% asked again in the training light (%d frames asked again), %d wrong\n",
      100 * alone.within_5cm_5deg, 100 * asked_again.within_5cm_5deg, retried,
      asked_again.wrong_answers);
  EXPECT_GT(retried, 0);
  EXPECT_GE(asked_again.within_5cm_5deg, 0.80);
  EXPECT_GE(asked_again.within_5cm_5deg, alone.within_5cm_5deg + 0.2);
  EXPECT_EQ(asked_again.wrong_answers, 0);
  // Two stops less light moves no colour but every value down the tone
  // curve: the nearest training view tells the level too.
  PhotometricChange dim;
  dim.stops = -2;
  const AccuracySummary dim_alone = accuracyUnder(own_colour, test_frames_, dim);
  const AccuracySummary dim_asked_again = accuracyUnder(retrying, test_frames_, dim);
  std::printf(
      "synthetic room trained in the recorded colour, two stops darker: %.1f%% in the frames' "
      "own light, %.1f%% asked again in the training light, %d wrong\n",
      100 * dim_alone.within_5cm_5deg, 100 * dim_asked_again.within_5cm_5deg,
      dim_asked_again.wrong_answers);
  EXPECT_GE(dim_asked_again.within_5cm_5deg, 0.80);
  EXPECT_GE(dim_asked_again.within_5cm_5deg, dim_alone.within_5cm_5deg + 0.2);
  EXPECT_EQ(dim_asked_again.wrong_answers, 0);
  RelocalizerParams negative = smallRelocalization();
  negative.light_retry_min_cast = -0.1f;
  EXPECT_NE(Relocalizer(retrying.model(), negative).validationError().find("light_retry_min_cast"),
            std::string::npos);
}

// The room's ground truth is exact, so depth ICP against the surface fused from
// the training frames must make the solver's poses more precise, and every
// answer must lie on the surface.
TEST_F(SyntheticRoomRelocalization, DepthIcpMakesPosesMorePreciseAndEveryAnswerLiesOnTheSurface) {
  std::vector<double> with_icp, without_icp;
  for (const RgbdFrame& frame : test_frames_) {
    const Relocalization checked = relocalizer_->relocalize(frame);
    const Relocalization solver_only = without_surface_->relocalize(frame);
    EXPECT_LT(solver_only.surface_agreement, 0.0f);  // not measured
    if (!checked.success || !solver_only.success) continue;
    EXPECT_GE(checked.surface_agreement, relocalizer_->params().surface.min_agreement);
    EXPECT_GT(checked.timings.surface, 0.0);
    with_icp.push_back(translationError(checked.pose, *frame.ground_truth));
    without_icp.push_back(translationError(solver_only.pose, *frame.ground_truth));
  }
  ASSERT_GT(with_icp.size(), 0.9 * test_frames_.size());
  const double median_icp = median(with_icp), median_solver = median(without_icp);
  std::printf("median translation error: %.2f mm with depth ICP, %.2f mm from the solver alone\n",
              1000 * median_icp, 1000 * median_solver);
  // The forests were trained on exact labels, so the solver is already at the
  // depth noise here; ICP must keep it there (test_surface shows it closing 2 cm).
  EXPECT_LT(median_icp, 1.2 * median_solver);
  EXPECT_LT(median_icp, 0.005);
}

// A frame of another room has no place in this one: whatever pose the forests'
// votes give it, its depth does not lie on this room's surface. With the
// solver's own evidence thresholds off, the surface check alone must refuse it.
TEST_F(SyntheticRoomRelocalization, TheSurfaceCheckAloneRefusesFramesOfAnotherRoom) {
  RelocalizerParams params = relocalizer_->params();
  params.solver.min_inliers = 0;
  params.solver.min_inlier_ratio = 0.0f;
  const Relocalizer surface_gate_only(relocalizer_->model(), params);
  const SyntheticRoom other(8);
  const SyntheticTrajectories paths = other.trajectories(10, 10);
  const CameraIntrinsics camera = smallCamera();
  int answered = 0, refused_by_surface = 0, without_hypothesis = 0;
  float highest = 0.0f;
  for (size_t i = 0; i < paths.test.size(); ++i) {
    const Relocalization r =
        surface_gate_only.relocalize(other.render(paths.test[i], camera, static_cast<int>(i)));
    answered += r.success ? 1 : 0;
    refused_by_surface += r.message.find("scene's surface") != std::string::npos ? 1 : 0;
    without_hypothesis += r.message.find("no pose hypothesis") != std::string::npos ? 1 : 0;
    highest = std::max(highest, r.surface_agreement);
  }
  std::printf(
      "another room: %d of %zu frames answered, %d refused by the surface check (highest "
      "agreement %.2f), %d without any rigid hypothesis\n",
      answered, paths.test.size(), refused_by_surface, highest, without_hypothesis);
  EXPECT_EQ(answered, 0);
  // A frame whose votes do not even form one rigid minimal set never reaches
  // the surface stage (that refusal cannot be turned off); every frame that
  // gets a pose must be refused by the surface check, and most must get one,
  // or this test would check nothing.
  EXPECT_EQ(refused_by_surface + without_hypothesis, static_cast<int>(paths.test.size()));
  EXPECT_GE(refused_by_surface, static_cast<int>(0.8 * paths.test.size()));
}

// A chance consensus is not found again by another draw of the frame; a
// right answer is (second_draw.h). With the solver's evidence thresholds and
// the surface check off, frames of another room get poses from chance
// consensuses, every one wrong. Asked to confirm every answer
// (confirm_below 1), the relocalizer gives almost none of them, and still
// answers the room's own frames, each confirmed, at the pose of its first draw.
TEST_F(SyntheticRoomRelocalization, ASecondDrawConfirmsRightAnswersAndNotChanceConsensuses) {
  RelocalizerParams ungated = relocalizer_->params();
  ungated.solver.min_inliers = 0;
  ungated.solver.min_inlier_ratio = 0.0f;
  ungated.surface.enabled = false;
  ungated.light_retry_min_cast = 0.0f;
  ungated.confirm_below = 0.0f;
  RelocalizerParams confirming = ungated;
  confirming.confirm_below = 1.0f;
  const Relocalizer once(relocalizer_->model(), ungated);
  const Relocalizer twice(relocalizer_->model(), confirming);

  const SyntheticRoom other(8);
  const SyntheticTrajectories paths = other.trajectories(10, 10);
  int chance = 0, chance_confirmed = 0;
  for (size_t i = 0; i < paths.test.size(); ++i) {
    const RgbdFrame frame = other.render(paths.test[i], smallCamera(), static_cast<int>(i));
    const Relocalization first = once.relocalize(frame);
    const Relocalization confirmed = twice.relocalize(frame);
    EXPECT_FALSE(first.second_draw);
    chance += first.success ? 1 : 0;
    chance_confirmed += confirmed.success ? 1 : 0;
    if (first.success && !confirmed.success) {
      EXPECT_TRUE(confirmed.second_draw);
      EXPECT_NE(confirmed.message.find("not confirmed"), std::string::npos) << confirmed.message;
    }
  }
  int own = 0, own_confirmed = 0;
  for (const RgbdFrame& frame : test_frames_) {
    const Relocalization first = once.relocalize(frame);
    const Relocalization confirmed = twice.relocalize(frame);
    own += first.success && translationError(first.pose, *frame.ground_truth) < 0.05 ? 1 : 0;
    if (!confirmed.success) continue;
    ++own_confirmed;
    EXPECT_TRUE(confirmed.second_draw);
    EXPECT_TRUE(confirmed.pose.isApprox(first.pose, 1e-9)) << "frame " << frame.id;
  }
  std::printf(
      "another room, every gate off: %d of %zu frames answered, %d of them confirmed by a second "
      "draw; the room's own frames: %d of %zu within 5 cm, %d confirmed\n",
      chance, paths.test.size(), chance_confirmed, own, test_frames_.size(), own_confirmed);
  // Most frames must get a chance pose, or this test would check nothing.
  EXPECT_GE(chance, static_cast<int>(0.8 * paths.test.size()));
  EXPECT_LE(chance_confirmed, static_cast<int>(0.1 * paths.test.size()));
  EXPECT_GE(own_confirmed, own - 1);
  for (float share : {-0.1f, 1.5f}) {
    RelocalizerParams refused = ungated;
    refused.confirm_below = share;
    EXPECT_NE(Relocalizer(relocalizer_->model(), refused).validationError().find("confirm_below"),
              std::string::npos);
  }
}

TEST_F(SyntheticRoomRelocalization, SameFrameSameAnswer) {
  const Relocalization a = relocalizer_->relocalize(test_frames_[3]);
  const Relocalization b = relocalizer_->relocalize(test_frames_[3]);
  ASSERT_EQ(a.success, b.success);
  EXPECT_TRUE(a.pose.isApprox(b.pose, 1e-12));
  EXPECT_EQ(a.point_inliers, b.point_inliers);
}

// What RViz draws of an answer: its inlier samples where the answer puts
// them. They are exactly the counted inliers, of both kinds, and lie on the
// room's surface, where the true pose puts them too.
TEST_F(SyntheticRoomRelocalization, InlierWorldPointsAreTheCountedInliersOnTheSurface) {
  const SurfaceModel& surface = relocalizer_->model().surface;
  ASSERT_FALSE(surface.empty());
  long points = 0, lines = 0, on_surface = 0, near_truth = 0;
  for (const RgbdFrame& frame : test_frames_) {
    const Relocalization r = relocalizer_->relocalize(frame);
    if (!r.success) {
      EXPECT_TRUE(r.point_inlier_world.empty() && r.line_inlier_world.empty());
      continue;
    }
    ASSERT_EQ(static_cast<int>(r.point_inlier_world.size()), r.point_inliers);
    ASSERT_EQ(static_cast<int>(r.line_inlier_world.size()), r.line_inliers);
    // The camera point of each sample, moved by the true pose instead.
    const Eigen::Isometry3f answer_to_truth =
        (*frame.ground_truth * r.pose.inverse()).cast<float>();
    for (const auto* kind : {&r.point_inlier_world, &r.line_inlier_world}) {
      for (const Eigen::Vector3f& world : *kind) {
        on_surface += surface.near(world) != nullptr;
        near_truth += (answer_to_truth * world - world).norm() < 0.02f;
      }
    }
    points += r.point_inliers;
    lines += r.line_inliers;
  }
  ASSERT_GT(points, 1000);
  EXPECT_GT(lines, 100);
  const long all = points + lines;
  std::printf(
      "inliers: %ld point and %ld line samples; %.1f%% on the surface, %.1f%% within 2 cm "
      "of where the true pose puts them\n",
      points, lines, 100.0 * on_surface / all, 100.0 * near_truth / all);
  EXPECT_GT(on_surface, 0.95 * all);
  EXPECT_GT(near_truth, 0.95 * all);
}

TEST_F(SyntheticRoomRelocalization, BadFramesAreExplicitFailures) {
  RgbdFrame frame = test_frames_[0];
  frame.depth.setTo(std::numeric_limits<float>::quiet_NaN());
  Relocalization r = relocalizer_->relocalize(frame);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("too little valid depth"), std::string::npos) << r.message;

  frame = test_frames_[0];
  frame.colour = cv::Mat(100, 100, CV_8UC3);
  r = relocalizer_->relocalize(frame);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("invalid frame"), std::string::npos) << r.message;
}
