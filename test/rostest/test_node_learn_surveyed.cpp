// Learn mode continuing a model made by `train` (issue 40): `model:=` names
// the fixture room's trained model, which has no key frames beside it. The
// node answers from it at once, as the place `learned` in map; the room's
// training loop, played with its poses on TF as SLAM publishes them, shows the
// room as it was surveyed, so what it sees lies on the survey's surface and
// next to nothing is learned again; ~save_model writes the survey into the
// folder unchanged, as a frozen submap without key frames.

#include <unistd.h>

#include <algorithm>
#include <filesystem>

#include "learn_bag.h"
#include "node_test_support.h"
#include "relocalizer/core/file_io.h"
#include "relocalizer/forest/model_io.h"

using namespace relocalizer_test;

TEST(LearnSurveyed, AModelMadeByTrainAnswersAndCoversTheRoomItSurveyed) {
  Listener<ResultMsg> results("/relocalizer/result", 1000);
  CameraPublisher camera;
  const std::vector<FrameMessages> test = loadFixtureFrames();
  // The node advertises its services once the survey has loaded.
  ASSERT_TRUE(ros::service::waitForService("/relocalizer/relocalize", ros::Duration(60)));
  const relocalizer::Relocalize::Response first =
      relocalizeUntilAnswered(camera, test[0], ros::WallTime::now() + ros::WallDuration(60.0));
  ASSERT_TRUE(first.success) << first.message;
  EXPECT_EQ(first.place, "learned");  // submap 0 alone answers as the place (learned_places.h)
  EXPECT_EQ(first.pose.header.frame_id, "map");
  EXPECT_LT(translationError(first.pose.pose.pose, test[0].truth), 0.05);

  ASSERT_GE(playLearnBag(camera), 50);
  const auto last = resultOfOneCall(camera, results, test[1]);
  ASSERT_TRUE(last.has_value());
  EXPECT_TRUE(last->learning);
  EXPECT_EQ(last->learning_error, "");
  std::printf("~result after the loop: %u key frames added, %u covered, %u submaps\n",
              last->keyframes_added, last->keyframes_covered, last->submaps);
  // The room is as surveyed: most of the loop's key frames are covered.
  EXPECT_GT(last->keyframes_covered, 2 * last->keyframes_added);

  const auto saved = saveAndReadFolder("relocalizer_surveyed_test_" + std::to_string(::getpid()));
  ASSERT_TRUE(saved.has_value());
  ASSERT_FALSE(saved->manifest.submaps.empty());
  const relocalizer::SubmapEntry& survey = saved->manifest.submaps[0];
  EXPECT_TRUE(survey.frozen);
  EXPECT_TRUE(survey.keyframe_poses.empty());
  std::string fixture;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("fixture", fixture));
  const auto written = relocalizer::readRegularFile(saved->path + "/" + survey.model,
                                                    relocalizer::modelFileFormat("model file"));
  const auto trained = relocalizer::readRegularFile(fixture + "/model.bin",
                                                    relocalizer::modelFileFormat("model file"));
  ASSERT_TRUE(written.ok()) << written.error();
  ASSERT_TRUE(trained.ok()) << trained.error();
  EXPECT_TRUE(*written == *trained) << "the survey was not written unchanged";
  std::filesystem::remove_all(saved->path);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_learn_surveyed");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
