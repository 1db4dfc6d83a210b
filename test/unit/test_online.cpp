// Online learning (online module): the compressed key-frame store and its file,
// and the learner on a generated room with exact ground truth: from nothing to
// a model that relocalizes held-out frames, bounded memory, saving and
// continuing a place.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>

#include "relocalizer/core/byte_io.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/eval/metrics.h"
#include "relocalizer/forest/model_builder.h"
#include "relocalizer/online/key_frame_feed.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/sim/synthetic_scene.h"
#include "support.h"

using namespace relocalizer;

namespace {

const CameraIntrinsics kCamera = CameraIntrinsics::kinectDefault().scaledTo(320, 240);

void writeBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

LearningParams smallLearning() { return relocalizer::testing::onlineRoomLearning(); }
RelocalizerParams fastRelocalizer() { return relocalizer::testing::onlineRoomRelocalizer(); }

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
  const ModelFileId model{0x12345678u, 4242};
  writeBytes(path, serializeKeyFrames(store.entries(), model));
  auto loaded = loadKeyFrames(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  ASSERT_TRUE(loaded->model.has_value());
  EXPECT_EQ(*loaded->model, model);
  ASSERT_EQ(loaded->key_frames.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const StoredKeyFrame& k = loaded->key_frames[i];
    EXPECT_EQ(k.id, store.entries()[i]->id);
    EXPECT_EQ(k.colour_jpeg, store.entries()[i]->colour_jpeg);
    EXPECT_EQ(k.depth_png, store.entries()[i]->depth_png);
    EXPECT_TRUE(k.pose.isApprox(store.entries()[i]->pose));
    EXPECT_EQ(k.camera.width, 320);
  }

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
  EXPECT_THROW(OnlineLearner(p, fastRelocalizer(), OnlineLearner::Mode::Inline),
               std::invalid_argument);
  EXPECT_EQ(learningParamsError(smallLearning()), "");
}

TEST(KeyFrameRule, MinMotionParsesAndFormatsBack) {
  auto both = parseMinMotion("0.05,5");
  ASSERT_TRUE(both.ok()) << both.error();
  EXPECT_EQ(both->metres, 0.05);
  EXPECT_EQ(both->degrees, 5.0);
  EXPECT_EQ(formatMinMotion(KeyFrameMotion{}), "0.05,5");
  auto metres_only = parseMinMotion(" 0.1 ");
  ASSERT_TRUE(metres_only.ok()) << metres_only.error();
  EXPECT_EQ(metres_only->degrees, 0.0);
  EXPECT_FALSE(parseMinMotion("0")->active());
  for (const char* bad : {"", ",", "0.05,", "far", "0.05,5,1", "-1", "nan", "0.05x"})
    EXPECT_FALSE(parseMinMotion(bad).ok()) << bad;
}

TEST(KeyFrameRule, KeepsAFrameThatMovedOrTurnedFromTheLastKeptOne) {
  const auto at = [](double x, double yaw_degrees) {
    Pose pose = Pose::Identity();
    pose.linear() =
        Eigen::AngleAxisd(yaw_degrees * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(x, 0, 0);
    return pose;
  };
  KeyFrameSelector selector(KeyFrameMotion{0.05, 5.0});
  EXPECT_TRUE(selector.keep(at(0, 0)));  // the first
  EXPECT_FALSE(selector.keep(at(0.03, 0)));
  EXPECT_TRUE(selector.keep(at(0.05, 0)));   // 5 cm from the first
  EXPECT_FALSE(selector.keep(at(0.09, 0)));  // 4 cm from the last kept one
  EXPECT_TRUE(selector.keep(at(0.05, 6)));   // turned
  KeyFrameSelector every(KeyFrameMotion{0, 0});
  EXPECT_TRUE(every.keep(at(0, 0)));
  EXPECT_TRUE(every.keep(at(0, 0)));
  // The store's distance is in default steps, whatever the rule keeps.
  EXPECT_NEAR(keyFrameDistance(at(0, 0), at(0.1, 10)), 4.0, 1e-9);
}

TEST(LearningParams, ReadOnceAndCheckedByName) {
  auto read = readLearningParams(LearningParams{}, "0.1,10", "");
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_EQ(read->min_motion.metres, 0.1);
  EXPECT_EQ(read->min_motion.degrees, 10.0);
  EXPECT_NE(readLearningParams(LearningParams{}, "far", "").error().find("min_motion"),
            std::string::npos);
  EXPECT_NE(
      readLearningParams(LearningParams{}, "0.05,5", "/nonexistent.yaml").error().find("config"),
      std::string::npos);
  // The retrain preset reads as a learning config and scores fewer candidates.
  auto fast = readLearningParams(LearningParams{}, "0.05,5",
                                 std::string(RELOCALIZER_SOURCE_DIR) + "/config/learn_fast.yaml");
  ASSERT_TRUE(fast.ok()) << fast.error();
  EXPECT_LT(fast->training.points.feature_candidates, read->training.points.feature_candidates);
  EXPECT_LT(fast->training.lines.feature_candidates, read->training.lines.feature_candidates);
  LearningParams few;
  few.max_keyframes = 1;
  EXPECT_NE(readLearningParams(few, "0.05,5", "").error().find("max_keyframes"), std::string::npos);
}

TEST(LearningParams, LearnedModelsAnswerWithTheirTwoOverrides) {
  RelocalizerParams offline;
  offline.max_leaves = 4;
  offline.surface.min_agreement = 0.5f;
  LearningParams learning;
  RelocalizerParams learned = learnedModelParams(learning, offline);
  EXPECT_EQ(learned.max_leaves, learning.min_backtracking_leaves);
  EXPECT_EQ(learned.surface.min_agreement, 0.0f);
  learning.surface_gate = true;
  EXPECT_EQ(learnedModelParams(learning, offline).surface.min_agreement, 0.5f);
}

// The builder fuses the surface before the forests release depth; the model
// is the one each part gives alone, so the order changes no byte.
TEST_F(OnlineRoom, ModelBuilderGivesTheForestsAndSurfaceOfTheirOwnTraining) {
  const TrainingParams params = smallLearning().training;
  std::vector<TrainingImage> images;
  ModelBuilder builder(params);
  for (const RgbdFrame& frame : learn_) {
    ASSERT_TRUE(appendTrainingImage(frame, params, images));
    ASSERT_TRUE(builder.add(frame));
  }
  RgbdFrame unposed = learn_.front();
  unposed.ground_truth.reset();
  EXPECT_FALSE(builder.add(unposed));
  TrainingSummary provenance;
  provenance.dataset = "room";
  provenance.threads = 3;
  int surfaces = 0;
  ModelBuildProgress progress;
  progress.surface_built = [&](double) { ++surfaces; };
  auto built = builder.build(provenance, progress);
  ASSERT_TRUE(built.ok()) << built.error();
  EXPECT_EQ(builder.size(), 0u);  // consumed
  EXPECT_EQ(surfaces, 1);
  EXPECT_EQ(built->summary.dataset, "room");
  EXPECT_EQ(built->summary.threads, 3);
  EXPECT_EQ(built->summary.images, static_cast<int>(learn_.size()));

  Model apart;
  apart.params = params;
  apart.summary = built->summary;
  apart.points = trainForest(images, ForestKind::Points, params);
  apart.lines = trainForest(images, ForestKind::Lines, params);
  apart.surface = buildSurface(images, params.surface);
  EXPECT_TRUE(serializeModel(*built) == serializeModel(apart));
  EXPECT_FALSE(ModelBuilder(params).build({}).ok());  // no images
}

// One feed for the node and the tools: the pose is checked before the rule,
// only key frames are loaded, and a frame that fails to load says why.
TEST_F(OnlineRoom, KeyFrameFeedLoadsAndLearnsOnlyKeyFrames) {
  LearningParams p = smallLearning();
  OnlineLearner learner(p, fastRelocalizer(), OnlineLearner::Mode::Inline);
  KeyFrameFeed feed(learner, p);
  using Outcome = KeyFrameFeed::Result::Outcome;
  int loads = 0;
  const auto load = [&](const RgbdFrame& frame) {
    return [&loads, &frame]() -> Expected<RgbdFrame> {
      ++loads;
      return frame;
    };
  };
  const RgbdFrame& first = learn_[0];
  EXPECT_EQ(feed.offer(std::nullopt, load(first)).outcome, Outcome::Untracked);
  Pose far = *first.ground_truth;
  far.translation().x() = 1e6;
  const KeyFrameFeed::Result bad = feed.offer(far, load(first));
  EXPECT_EQ(bad.outcome, Outcome::Untracked);
  EXPECT_NE(bad.why.find("map origin"), std::string::npos);
  EXPECT_EQ(loads, 0);
  EXPECT_EQ(feed.offer(*first.ground_truth, load(first)).outcome, Outcome::Learned);
  EXPECT_EQ(feed.offer(*first.ground_truth, load(first)).outcome, Outcome::NotKeyFrame);
  EXPECT_EQ(loads, 1);
  const KeyFrameFeed::Result failed = feed.offer(
      *learn_[1].ground_truth, []() -> Expected<RgbdFrame> { return makeError("unreadable"); });
  EXPECT_EQ(failed.outcome, Outcome::Failed);
  EXPECT_EQ(failed.why, "unreadable");
  EXPECT_EQ(feed.offer(*learn_[2].ground_truth, load(learn_[2])).outcome, Outcome::Learned);
  EXPECT_EQ(learner.status().keyframes_added, 2);
  ASSERT_TRUE(feed.learner().drain().ok());
  EXPECT_TRUE(learner.current());
  EXPECT_EQ(feed.learner().places().size(), 1u);
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
    for (size_t i = 0; i < half; ++i)
      ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
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
  std::printf("online room model from %zu key frames: %.0f%% within 5 cm / 5 deg\n", learn_.size(),
              100 * share);
  EXPECT_GE(share, 0.8);
}

// The store's cap holds however many key frames arrive, and the model follows
// the store.
// The key frames are decoded in parallel but trained on in store order: the
// model is the one ModelBuilder makes of them one by one, and the retrain's
// stage times add up to at most its wall time.
TEST_F(OnlineRoom, RetrainTrainsOnTheDecodedKeyFramesInStoreOrder) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  OnlineLearner learner(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  for (const RgbdFrame& frame : learn_)
    ASSERT_TRUE(learner.addKeyFrame(frame, *frame.ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  const Model& learned = learner.current()->model();

  ModelBuilder builder(learned.params);
  for (const KeyFrameStore::Entry& entry : learner.keyFrames()) {
    auto image = decompressKeyFrame(*entry);
    ASSERT_TRUE(image.ok()) << image.error();
    builder.add(std::move(*image));
  }
  auto serial = builder.build(learned.summary);
  ASSERT_TRUE(serial.ok()) << serial.error();
  serial->summary.seconds = learned.summary.seconds;
  EXPECT_TRUE(serializeModel(*serial) == serializeModel(learned));

  const LearningStatus status = learner.status();
  const RetrainStages& t = status.last_retrain_stages;
  for (double stage : {t.decode, t.surface, t.sampling, t.growing, t.serving})
    EXPECT_GE(stage, 0.0);
  EXPECT_GT(t.growing, 0.0);
  EXPECT_LE(t.decode + t.surface + t.sampling + t.growing + t.serving,
            status.last_retrain_seconds + 1e-6);
}

// A learner whose training normalises colour trains its forests on the key
// frames as the relocalizer will see the frames it is asked about: the model
// is the one ModelBuilder makes of the same frames given as recorded frames.
TEST_F(OnlineRoom, ALearnedModelSeesTheColourNormalisationItIsStoredWith) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  LearningParams p = smallLearning();
  p.training.colour_normalisation = ColourNormalisation::kChannelStatistics;
  OnlineLearner learner(p, fastRelocalizer(), OnlineLearner::Mode::Inline);
  for (const RgbdFrame& frame : learn_)
    ASSERT_TRUE(learner.addKeyFrame(frame, *frame.ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  const Model& learned = learner.current()->model();
  ASSERT_EQ(learned.params.colour_normalisation, ColourNormalisation::kChannelStatistics);

  ModelBuilder builder(learned.params);
  for (const KeyFrameStore::Entry& entry : learner.keyFrames()) {
    auto image = decompressKeyFrame(*entry);
    ASSERT_TRUE(image.ok()) << image.error();
    RgbdFrame recorded;
    recorded.colour = image->colour;
    recorded.depth = image->depth;
    recorded.camera = image->camera;
    recorded.ground_truth = image->pose;
    ASSERT_TRUE(builder.add(recorded));
  }
  auto reference = builder.build(learned.summary);
  ASSERT_TRUE(reference.ok()) << reference.error();
  reference->summary.seconds = learned.summary.seconds;
  EXPECT_TRUE(serializeModel(*reference) == serializeModel(learned));
}

TEST_F(OnlineRoom, StoreStaysWithinItsCap) {
  LearningParams p = smallLearning();
  p.max_keyframes = 4;
  OnlineLearner learner(p, fastRelocalizer(), OnlineLearner::Mode::Inline);
  for (const RgbdFrame& frame : learn_)
    ASSERT_TRUE(learner.addKeyFrame(frame, *frame.ground_truth).ok());
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
  for (size_t i = 0; i < 4; ++i)
    ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  EXPECT_EQ(learner.current()->model().params.points.samples_per_image, 2000);  // 8000 / 4
  EXPECT_EQ(learner.current()->model().params.lines.samples_per_image, 2000);
  for (size_t i = 4; i < learn_.size(); ++i)
    ASSERT_TRUE(learner.addKeyFrame(learn_[i], *learn_[i].ground_truth).ok());
  ASSERT_TRUE(learner.drain().ok());
  EXPECT_EQ(learner.current()->model().params.points.samples_per_image,
            1000);  // 400, raised to the floor
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
  for (const RgbdFrame& frame : learn_)
    ASSERT_TRUE(learner->addKeyFrame(frame, *frame.ground_truth).ok());
  const std::shared_ptr<const Relocalizer> held = learner->current();
  learner.reset();
  if (held) {
    EXPECT_FALSE(held->model().points.empty());  // a model handed out outlives its learner
  }
}

// Saving and loading a place (issue 23): what a careless or hostile path, an
// interrupted save or a damaged key-frame file used to do, each reproduced.

namespace {

// A learner whose model was trained on `learn_[first, first + count)`.
std::unique_ptr<OnlineLearner> trainedLearner(const std::vector<RgbdFrame>& frames, size_t first,
                                              size_t count) {
  auto learner = std::make_unique<OnlineLearner>(smallLearning(), fastRelocalizer(),
                                                 OnlineLearner::Mode::Inline);
  for (size_t i = first; i < first + count; ++i)
    EXPECT_TRUE(learner->addKeyFrame(frames[i], *frames[i].ground_truth).ok());
  EXPECT_TRUE(learner->drain().ok());
  return learner;
}

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A pid no process has: a child that has exited and been reaped.
pid_t deadPid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  return child;
}

}  // namespace

// B3: any peer could make ~save_model replace a symlink, a FIFO, a device or
// any file the node can write (~/.bashrc) with a model.
TEST_F(OnlineRoom, SaveRefusesTargetsThatAreNotItsOwnFiles) {
  relocalizer::testing::TempDir dir;
  auto learner = trainedLearner(learn_, 0, 2);
  const std::string victim = dir.str() + "/victim";
  std::ofstream(victim) << "alias ls='ls --color'\n";

  const std::string link = dir.str() + "/link.model";
  std::filesystem::create_symlink(victim, link);
  Status saved = learner->save(link);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), link + ": is a symbolic link")) << saved.error();
  EXPECT_TRUE(std::filesystem::is_symlink(link));

  const std::string fifo = dir.str() + "/fifo.model";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  saved = learner->save(fifo);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), fifo + ": is not a regular file")) << saved.error();
  EXPECT_EQ(std::filesystem::status(fifo).type(), std::filesystem::file_type::fifo);

  saved = learner->save(victim);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), victim + ": exists and is not a relocalizer model"))
      << saved.error();
  EXPECT_EQ(readText(victim), "alias ls='ls --color'\n");

  // The key-frame companion is checked as strictly, before anything is written.
  const std::string model = dir.str() + "/place.model";
  std::filesystem::create_symlink(victim, keyFramesPath(model));
  saved = learner->save(model);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), keyFramesPath(model) + ": is a symbolic link"))
      << saved.error();
  EXPECT_FALSE(std::filesystem::exists(model));
  EXPECT_EQ(readText(victim), "alias ls='ls --color'\n");

  // Its own files it replaces: saving twice to one path is the normal case.
  std::filesystem::remove(keyFramesPath(model));
  ASSERT_TRUE(learner->save(model).ok());
  const Status again = learner->save(model);
  EXPECT_TRUE(again.ok()) << again.error();
}

// Weak messages: a directory gave "cannot rename ...: Success" and left
// DIR.keyframes behind; a missing folder, /proc or a too long name gave no reason.
TEST_F(OnlineRoom, FailedSavesSayWhy) {
  relocalizer::testing::TempDir dir;
  auto learner = trainedLearner(learn_, 0, 2);

  const std::string folder = dir.str() + "/folder";
  std::filesystem::create_directory(folder);
  Status saved = learner->save(folder);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), folder + ": is a directory")) << saved.error();
  EXPECT_FALSE(std::filesystem::exists(keyFramesPath(folder)));

  const std::string missing = dir.str() + "/no/such/folder/place.model";
  saved = learner->save(missing);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), systemErrorText(ENOENT))) << saved.error();
  EXPECT_TRUE(contains(saved.error(), missing)) << saved.error();

  const std::string long_name = dir.str() + "/" + std::string(250, 'm');
  saved = learner->save(long_name);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), systemErrorText(ENAMETOOLONG))) << saved.error();

  // Whatever /proc answers to this user, the message must carry it.
  const std::string in_proc = "/proc/relocalizer_test.model";
  const int probe = ::open((in_proc + ".probe").c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
  const int probe_errno = errno;
  ASSERT_LT(probe, 0);
  saved = learner->save(in_proc);
  ASSERT_FALSE(saved.ok());
  EXPECT_TRUE(contains(saved.error(), systemErrorText(probe_errno))) << saved.error();
}

// B4: temporaries of a save that was killed were left behind for good.
TEST_F(OnlineRoom, SaveRemovesTemporariesThatAKilledSaveLeft) {
  relocalizer::testing::TempDir dir;
  auto learner = trainedLearner(learn_, 0, 2);
  const std::string model = dir.str() + "/place.model";
  const std::string dead = std::to_string(deadPid());
  std::ofstream(model + ".tmp" + dead) << "half a model";
  std::ofstream(keyFramesPath(model) + ".tmp" + dead) << "half the key frames";
  // Someone else's file that only looks similar stays.
  std::ofstream(model + ".tmp" + dead + "x") << "not ours";
  ASSERT_TRUE(learner->save(model).ok());
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"place.model", "place.model.keyframes",
                                             "place.model.tmp" + dead + "x"}));
}

// B4: killed between the two renames, new key frames sat beside the old model
// and learn mode resumed the pair as if the model knew them. Built here as the
// crash leaves it: the newer save's key frames, the older save's model.
TEST_F(OnlineRoom, ResumingAMismatchedPairRetrainsOnTheKeyFrames) {
  relocalizer::testing::TempDir dir;
  const std::string model = dir.str() + "/place.model";
  const std::string old_model = dir.str() + "/old.model";
  ASSERT_TRUE(trainedLearner(learn_, 0, 2)->save(model).ok());
  std::filesystem::copy_file(model, old_model);
  ASSERT_TRUE(trainedLearner(learn_, 0, 4)->save(model).ok());
  std::filesystem::copy_file(old_model, model, std::filesystem::copy_options::overwrite_existing);

  OnlineLearner resumed(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  ASSERT_TRUE(resumed.resume(model).ok());
  EXPECT_EQ(resumed.current(), nullptr);  // the old model is not served as if it knew them
  const LearningStatus status = resumed.status();
  EXPECT_EQ(status.keyframes_stored, 4);
  EXPECT_TRUE(contains(status.last_error, model)) << status.last_error;
  EXPECT_TRUE(contains(status.last_error, keyFramesPath(model))) << status.last_error;
  ASSERT_TRUE(resumed.drain().ok());
  ASSERT_NE(resumed.current(), nullptr);
  EXPECT_EQ(resumed.current()->model().summary.images, 4);

  // A pair from one save resumes as saved: its model serves at once.
  OnlineLearner matched(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  ASSERT_TRUE(trainedLearner(learn_, 0, 4)->save(model).ok());
  ASSERT_TRUE(matched.resume(model).ok());
  EXPECT_NE(matched.current(), nullptr);
  EXPECT_EQ(matched.status().last_error, "");
}

// B5: the count in the header (outside the CRC) was trusted: 4,000,000 made
// the loader allocate 1 GB, 2^32-1 threw std::bad_alloc.
TEST_F(OnlineRoom, KeyFrameCountIsBoundedByTheFile) {
  relocalizer::testing::TempDir dir;
  const std::string path = dir.str() + "/place.keyframes";
  KeyFrameStore store(8);
  auto k = compressKeyFrame(learn_[0], *learn_[0].ground_truth);
  ASSERT_TRUE(k.ok());
  store.add(std::make_shared<const StoredKeyFrame>(std::move(*k)));
  for (const uint32_t count : {4000000u, 0xFFFFFFFFu}) {
    writeBytes(path, serializeKeyFrames(store.entries(), ModelFileId{}));
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(12);  // magic, version, then the count
    file.write(reinterpret_cast<const char*>(&count), sizeof count);
    file.close();
    auto loaded = loadKeyFrames(path);
    ASSERT_FALSE(loaded.ok());
    EXPECT_TRUE(contains(loaded.error(), path + ": ")) << loaded.error();
    EXPECT_TRUE(contains(loaded.error(), std::to_string(count) + " key frames")) << loaded.error();
  }
}

// B6: a FIFO at MODEL.keyframes hung learn-mode start-up for good.
TEST_F(OnlineRoom, KeyFrameLoaderRefusesAFifo) {
  relocalizer::testing::TempDir dir;
  const std::string fifo = dir.str() + "/place.keyframes";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto loading = std::async(std::launch::async, [&] { return loadKeyFrames(fifo); });
  if (loading.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    // Release the loader (a writer that closes at once gives it end of file).
    ::close(::open(fifo.c_str(), O_WRONLY | O_NONBLOCK));
    FAIL() << "loadKeyFrames blocks on a FIFO";
  }
  auto loaded = loading.get();
  ASSERT_FALSE(loaded.ok());
  EXPECT_TRUE(contains(loaded.error(), fifo + ": is not a regular file")) << loaded.error();
}

// B7: learn mode took any SLAM pose, 1e30 m included, and answered there.
// The feed is the one place a SLAM pose is judged: nothing unusable reaches
// the learner, and the frame is not even loaded.
TEST_F(OnlineRoom, FeedRefusesImplausibleSlamPoses) {
  OnlineLearner learner(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  KeyFrameFeed feed(learner, smallLearning());
  const RgbdFrame& frame = learn_[0];
  int loads = 0;
  const auto load = [&]() -> Expected<RgbdFrame> {
    ++loads;
    return frame;
  };
  Pose far = *frame.ground_truth;
  far.translation().x() = 1e30;
  Pose nan = *frame.ground_truth;
  nan.translation().y() = std::numeric_limits<double>::quiet_NaN();
  Pose scaled = *frame.ground_truth;
  scaled.linear() *= 2.0;
  Pose mirrored = *frame.ground_truth;
  mirrored.linear().col(0) *= -1.0;
  for (const auto& [pose, why] :
       std::vector<std::pair<Pose, std::string>>{{far, "from the map origin"},
                                                 {nan, "not finite"},
                                                 {scaled, "not a rotation"},
                                                 {mirrored, "not a rotation"}}) {
    const KeyFrameFeed::Result fed = feed.offer(pose, load);
    EXPECT_EQ(fed.outcome, KeyFrameFeed::Result::Outcome::Untracked) << why;
    EXPECT_TRUE(contains(fed.why, why)) << fed.why;
  }
  EXPECT_EQ(loads, 0);
  EXPECT_EQ(learner.summary().keyframes_added, 0);
  EXPECT_EQ(feed.offer(*frame.ground_truth, load).outcome, KeyFrameFeed::Result::Outcome::Learned);
  EXPECT_EQ(learner.summary().keyframes_added, 1);
}

// Key-frame files from before the model identity (version 1) still load and
// continue their place as they did.
TEST_F(OnlineRoom, VersionOneKeyFrameFilesStillLoadAndResume) {
  relocalizer::testing::TempDir dir;
  const std::string model = dir.str() + "/place.model";
  ASSERT_TRUE(trainedLearner(learn_, 0, 2)->save(model).ok());
  // Version 1 is version 2 without the 12 bytes of model identity that open the body.
  std::ifstream in(keyFramesPath(model), std::ios::binary);
  std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  constexpr size_t kHeader = 28, kIdentity = 12;
  const std::vector<uint8_t> body(file.begin() + kHeader + kIdentity, file.end());
  const uint32_t version = 1, count = 2, crc = crc32Of(body.data(), body.size());
  const uint64_t length = body.size();
  std::vector<uint8_t> v1(file.begin(), file.begin() + 8);  // the magic
  ByteWriter w(v1);
  w.value(version);
  w.value(count);
  w.value(length);
  w.value(crc);
  w.bytes(body.data(), body.size());
  writeBytes(keyFramesPath(model), v1);

  auto loaded = loadKeyFrames(keyFramesPath(model));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  EXPECT_FALSE(loaded->model.has_value());
  EXPECT_EQ(loaded->key_frames.size(), static_cast<size_t>(count));
  OnlineLearner resumed(smallLearning(), fastRelocalizer(), OnlineLearner::Mode::Inline);
  ASSERT_TRUE(resumed.resume(model).ok());
  EXPECT_NE(resumed.current(), nullptr);
  EXPECT_EQ(resumed.status().last_error, "");
}
