// Online learning (online module): the compressed key-frame store and its file,
// and the learner on a generated room with exact ground truth: from nothing to
// a model that relocalizes held-out frames, bounded memory, saving and
// continuing a place.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "relocalizer/eval/metrics.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);

// Small forests: the room needs no more, and a retrain of 20 key frames stays
// a few seconds.
LearningParams smallLearning() {
  LearningParams p;
  for (ForestParams* f : {&p.training.points, &p.training.lines}) {
    f->trees = 3;
    f->max_depth = 16;
    f->samples_per_image = 1000;
  }
  return p;
}

RelocalizerParams fastRelocalizer() {
  RelocalizerParams r;
  r.point_samples = 1000;
  r.line_samples = 500;
  r.solver.hypotheses = 256;
  return r;
}

class OnlineRoom : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    room_ = new SyntheticRoom(7);
    const SyntheticTrajectories paths = room_->trajectories(80, 20);
    // Every fourth frame of the training loop: what the 5 cm / 5 deg rule keeps.
    for (size_t i = 0; i < paths.train.size(); i += 4)
      learn_.push_back(room_->render(paths.train[i], kCamera, static_cast<int>(i)));
    for (size_t i = 0; i < paths.test.size(); ++i)
      test_.push_back(room_->render(paths.test[i], kCamera, static_cast<int>(100 + i)));
  }
  static void TearDownTestSuite() {
    delete room_;
    learn_.clear();
    test_.clear();
  }
  static double accuracy(const Relocalizer& relocalizer) {
    int good = 0;
    for (const RgbdFrame& frame : test_) {
      const Relocalization r = relocalizer.relocalize(frame);
      if (r.success && translationError(r.pose, *frame.ground_truth) < 0.05 &&
          rotationErrorDegrees(r.pose, *frame.ground_truth) < 5.0)
        ++good;
    }
    return static_cast<double>(good) / test_.size();
  }
  static SyntheticRoom* room_;
  static std::vector<RgbdFrame> learn_, test_;
};
SyntheticRoom* OnlineRoom::room_ = nullptr;
std::vector<RgbdFrame> OnlineRoom::learn_, OnlineRoom::test_;

}  // namespace

TEST_F(OnlineRoom, StoredKeyFrameKeepsDepthToTheMillimetreAndColourCloseToTheOriginal) {
  const RgbdFrame& frame = learn_.front();
  auto stored = compressKeyFrame(frame, *frame.ground_truth);
  ASSERT_TRUE(stored.ok()) << stored.error();
  const size_t raw = frame.colour.total() * 3 + frame.depth.total() * 4;
  EXPECT_LT(stored->colour_jpeg.size() + stored->depth_png.size(), raw / 4);
  auto image = decompressKeyFrame(*stored);
  ASSERT_TRUE(image.ok()) << image.error();
  EXPECT_TRUE(image->pose.isApprox(*frame.ground_truth));
  int compared = 0;
  for (int v = 0; v < frame.depth.rows; ++v)
    for (int u = 0; u < frame.depth.cols; ++u) {
      const float a = frame.depth.at<float>(v, u), b = image->depth.at<float>(v, u);
      ASSERT_EQ(std::isnan(a), std::isnan(b)) << u << "," << v;
      if (std::isnan(a)) continue;
      ASSERT_NEAR(a, b, 0.0005f);
      ++compared;
    }
  EXPECT_GT(compared, 1000);
  cv::Mat difference;
  cv::absdiff(frame.colour, image->colour, difference);
  // JPEG q95 on the room's fine procedural textures: measured 8.2 grey levels
  // on average (real Kinect images lose less); a wrong channel order or a
  // broken decode is off by tens.
  EXPECT_LT(cv::mean(difference)[0], 12.0);
}

TEST_F(OnlineRoom, FullStoreEvictsTheOlderOfTheTwoClosestKeyFrames) {
  KeyFrameStore store(3);
  const auto at = [&](int id, double x) {
    auto k = std::make_shared<StoredKeyFrame>();
    k->id = id;
    k->pose = Pose::Identity();
    k->pose.translation().x() = x;
    return k;
  };
  EXPECT_FALSE(store.add(at(0, 0.0)));
  EXPECT_FALSE(store.add(at(1, 1.0)));
  EXPECT_FALSE(store.add(at(2, 1.01)));  // 1 cm from key frame 1
  EXPECT_TRUE(store.add(at(3, 2.0)));
  ASSERT_EQ(store.size(), 3u);
  EXPECT_EQ(store.entries()[0]->id, 0);
  EXPECT_EQ(store.entries()[1]->id, 2);
  EXPECT_EQ(store.entries()[2]->id, 3);
}

TEST_F(OnlineRoom, KeyFrameFileRoundTripsAndRefusesCorruption) {
  relocalizer::testing::TempDir dir;
  const std::string path = dir.str() + "/place.keyframes";
  KeyFrameStore store(8);
  for (int i = 0; i < 2; ++i) {
    auto k = compressKeyFrame(learn_[i], *learn_[i].ground_truth);
    ASSERT_TRUE(k.ok());
    store.add(std::make_shared<const StoredKeyFrame>(std::move(*k)));
  }
  ASSERT_TRUE(saveKeyFrames(store.entries(), path).ok());
  auto loaded = loadKeyFrames(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  ASSERT_EQ(loaded->size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ((*loaded)[i].id, store.entries()[i]->id);
    EXPECT_EQ((*loaded)[i].colour_jpeg, store.entries()[i]->colour_jpeg);
    EXPECT_EQ((*loaded)[i].depth_png, store.entries()[i]->depth_png);
    EXPECT_TRUE((*loaded)[i].pose.isApprox(store.entries()[i]->pose));
    EXPECT_EQ((*loaded)[i].camera.width, 320);
  }
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp" + std::to_string(::getpid())));

  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  file.seekp(200);
  file.put('\x5a');
  file.close();
  auto corrupt = loadKeyFrames(path);
  ASSERT_FALSE(corrupt.ok());
  EXPECT_NE(corrupt.error().find("CRC"), std::string::npos) << corrupt.error();
  std::filesystem::resize_file(path, 100);
  auto truncated = loadKeyFrames(path);
  ASSERT_FALSE(truncated.ok());
  EXPECT_NE(truncated.error().find("truncated"), std::string::npos) << truncated.error();
}

TEST_F(OnlineRoom, ParametersAreCheckedByName) {
  LearningParams p = smallLearning();
  p.max_keyframes = 1;
  EXPECT_NE(learningParamsError(p).find("max_keyframes"), std::string::npos);
  p = smallLearning();
  p.first_retrain = 0;
  EXPECT_NE(learningParamsError(p).find("first_retrain"), std::string::npos);
  p = smallLearning();
  p.retrain_growth = -1;
  EXPECT_NE(learningParamsError(p).find("retrain_growth"), std::string::npos);
  EXPECT_THROW(OnlineLearner(p, fastRelocalizer(), OnlineLearner::Mode::Inline), std::invalid_argument);
  EXPECT_EQ(learningParamsError(smallLearning()), "");
}

// From nothing: no model until a retrain, then one that relocalizes frames of
// another path through the room; saved and continued, it keeps its key frames
// and grows.
TEST_F(OnlineRoom, LearnsThePlaceFromNothingSavesAndContinuesIt) {
  relocalizer::testing::TempDir dir;
  const std::string path = dir.str() + "/room.model";
  const size_t half = learn_.size() / 2;
  {
    OnlineLearner learner(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
    EXPECT_EQ(learner.current(), nullptr);
    EXPECT_FALSE(learner.save(path).ok());
    for (size_t i = 0; i < half; ++i) ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
    EXPECT_EQ(learner.current(), nullptr);  // Inline: nothing trains before drain()
    EXPECT_EQ(learner.status().backlog, static_cast<int>(half));
    ASSERT_TRUE(learner.drain().ok());
    const LearningStatus status = learner.status();
    EXPECT_EQ(status.keyframes_learned, static_cast<int>(half));
    EXPECT_EQ(status.backlog, 0);
    EXPECT_EQ(status.retrains, 1);
    EXPECT_GT(status.model_bytes, 0u);
    auto model = learner.current();
    ASSERT_NE(model, nullptr);
    EXPECT_EQ(model->model().summary.images, static_cast<int>(half));
    EXPECT_FALSE(model->model().surface.empty());
    ASSERT_TRUE(learner.save(path).ok());
  }
  ASSERT_TRUE(std::filesystem::exists(path));
  ASSERT_TRUE(std::filesystem::exists(keyFramesPath(path)));
  {
    // A model without its key frames cannot be continued: retraining would
    // forget everything it was trained on.
    const std::string lonely = dir.str() + "/lonely.model";
    std::filesystem::copy_file(path, lonely);
    OnlineLearner learner(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
    const Status resumed = learner.resume(lonely);
    ASSERT_FALSE(resumed.ok());
    EXPECT_NE(resumed.error().find("lonely.model.keyframes"), std::string::npos) << resumed.error();
  }

  OnlineLearner continued(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  ASSERT_TRUE(continued.resume(path).ok());
  ASSERT_NE(continued.current(), nullptr);  // serves at once
  EXPECT_EQ(continued.status().keyframes_learned, static_cast<int>(half));
  for (size_t i = half; i < learn_.size(); ++i)
    ASSERT_TRUE(continued.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(continued.drain().ok());
  EXPECT_EQ(continued.current()->model().summary.images, static_cast<int>(learn_.size()));
  const double share = accuracy(*continued.current());
  std::printf("online room model from %zu key frames: %.0f%% within 5 cm / 5 deg\n", learn_.size(), 100 * share);
  EXPECT_GE(share, 0.8);
}

// The store's cap holds however many key frames arrive, and the model follows
// the store.
TEST_F(OnlineRoom, StoreStaysWithinItsCap) {
  LearningParams p = smallLearning();
  p.max_keyframes = 4;
  OnlineLearner learner(p, fastRelocalizer(), OnlineLearner::Mode::Inline);
  for (const RgbdFrame& frame : learn_) ASSERT_TRUE(learner.addKeyFrame(frame, *frame.ground_truth).ok());
  const LearningStatus before = learner.status();
  EXPECT_EQ(before.keyframes_added, static_cast<int>(learn_.size()));
  EXPECT_EQ(before.keyframes_stored, 4);
  EXPECT_EQ(before.keyframes_evicted, static_cast<int>(learn_.size()) - 4);
  ASSERT_TRUE(learner.drain().ok());
  EXPECT_EQ(learner.current()->model().summary.images, 4);
}

// The sample budget spreads a fixed number of samples per tree over the key
// frames, and the model file records what was used.
TEST_F(OnlineRoom, SampleBudgetSetsSamplesPerImage) {
  LearningParams p = smallLearning();
  p.training.points.samples_per_image = 3000;
  p.training.lines.samples_per_image = 3000;
  p.samples_budget_per_tree = 8000;
  OnlineLearner learner(p, fastRelocalizer(), OnlineLearner::Mode::Inline);
  for (size_t i = 0; i < 4; ++i) ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  EXPECT_EQ(learner.current()->model().params.points.samples_per_image, 2000);  // 8000 / 4
  EXPECT_EQ(learner.current()->model().params.lines.samples_per_image, 2000);
  for (size_t i = 4; i < learn_.size(); ++i)
    ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  EXPECT_EQ(learner.current()->model().params.points.samples_per_image, 1000);  // 400, raised to the floor
}

// The worker thread: drain() waits for it, and the model it swaps in knows
// every key frame; earlier models stay valid for whoever still holds them.
TEST_F(OnlineRoom, BackgroundWorkerCatchesUpOnDrain) {
  OnlineLearner learner(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Background);
  std::shared_ptr<const Relocalizer> first;
  for (size_t i = 0; i < learn_.size(); ++i) {
    ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
    if (!first) first = learner.current();
  }
  ASSERT_TRUE(learner.drain().ok());
  const LearningStatus status = learner.status();
  EXPECT_EQ(status.backlog, 0);
  EXPECT_FALSE(status.retraining);
  EXPECT_GE(status.retrains, 1);
  EXPECT_EQ(status.keyframes_learned, static_cast<int>(learn_.size()));
  EXPECT_EQ(learner.current()->model().summary.images, static_cast<int>(learn_.size()));
  if (first) {
    EXPECT_FALSE(first->model().points.empty());
  }
  EXPECT_EQ(status.last_error, "");
}

// Shutdown while a retrain runs: the retrain is abandoned, not awaited, and
// nothing it had is used after the learner is gone.
TEST_F(OnlineRoom, DestroyingTheLearnerDuringARetrainIsSafe) {
  auto learner = std::make_unique<OnlineLearner>(smallLearning(), fastRelocalizer(),
                                                 OnlineLearner::Mode::Background);
  for (const RgbdFrame& frame : learn_) ASSERT_TRUE(learner->addKeyFrame(frame, *frame.ground_truth).ok());
  const std::shared_ptr<const Relocalizer> held = learner->current();
  learner.reset();
  if (held) {
    EXPECT_FALSE(held->model().points.empty());  // a model handed out outlives its learner
  }
}
