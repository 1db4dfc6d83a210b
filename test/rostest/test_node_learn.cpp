// Learn mode: the node learns the fixture room from a bag whose camera poses
// are on TF as a SLAM system publishes them (map -> odom -> camera), starting
// from no model; SLAM's TF jumps 2.5 m for five frames of every ten (issue 38),
// which the node must refuse and count, not learn. Then TF stops, as when
// tracking is lost, and ~relocalize must place held-out frames of the room
// within 5 cm / 5 deg.

#include <relocalizer/ListPlaces.h>
#include <relocalizer/SaveModel.h>
#include <relocalizer/UnloadPlace.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "learn_bag.h"
#include "node_test_support.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/keyframe_store.h"
#include "relocalizer/online/submap_folder.h"

using namespace relocalizer_test;

TEST(LearnMode, LearnsFromSlamPosesThenRelocalizesOnceTrackingIsLost) {
  Listener<ResultMsg> results("/relocalizer/result", 1000);
  CameraPublisher camera;
  const int played = playLearnBag(camera, [](tf2_msgs::TFMessage& message, int index) {
    if (index % 10 < 5) return;
    for (geometry_msgs::TransformStamped& t : message.transforms)
      if (t.header.frame_id == "map") t.transform.translation.x += 2.5;
  });
  ASSERT_GE(played, 50);

  // Tracking lost: frames now come without TF. Held-out frames of the room,
  // each retried until the learned model answers; every answer must be right.
  const std::vector<FrameMessages> frames = loadFixtureFrames();
  int answered = 0;
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(90.0);
  for (size_t i = 0; i < frames.size() && answered < 3 && ros::WallTime::now() < give_up; i += 5) {
    const FrameMessages& frame = frames[i];
    // A young model may lack the evidence for these views ("no model yet",
    // "weak evidence"); whatever it answers must be right.
    const relocalizer::Relocalize::Response response =
        relocalizeUntilAnswered(camera, frame, give_up);
    ASSERT_TRUE(response.success) << "frame " << i << ": " << response.message;
    EXPECT_LT(translationError(response.pose.pose.pose, frame.truth), 0.05) << "frame " << i;
    EXPECT_LT(rotationError(response.pose.pose.pose, frame.truth), 5.0) << "frame " << i;
    // The learned model is a place of its own, in map_frame.
    EXPECT_EQ(response.place, "learned") << "frame " << i;
    EXPECT_EQ(response.pose.header.frame_id, "map") << "frame " << i;
    ++answered;
  }
  EXPECT_EQ(answered, 3);

  // The place loaded beside it answers its own room, and the listing shows both.
  FrameMessages other = loadFixtureFrames("scene2")[5];
  const relocalizer::Relocalize::Response beside = callWhilePublishing(
      [&] {
        other.stamp(ros::Time::now());
        camera.publish(other);
      },
      5.0);
  ASSERT_TRUE(beside.success) << beside.message;
  EXPECT_EQ(beside.place, "room2");
  EXPECT_EQ(beside.pose.header.frame_id, "room2_map");
  EXPECT_LT(translationError(beside.pose.pose.pose, other.truth), 0.05);
  relocalizer::ListPlaces listing;
  ASSERT_TRUE(ros::service::call("/relocalizer/list_places", listing));
  ASSERT_EQ(listing.response.places.size(), 2u);
  EXPECT_EQ(listing.response.places[0].name, "room2");
  EXPECT_EQ(listing.response.places[1].name, "learned");
  EXPECT_EQ(listing.response.places[1].model, "");
  EXPECT_GE(listing.response.places[1].training_frames, 2u);
  // The learned place follows the learner: it cannot be unloaded.
  relocalizer::UnloadPlace unload;
  unload.request.name = "learned";
  ASSERT_TRUE(ros::service::call("/relocalizer/unload_place", unload));
  EXPECT_FALSE(unload.response.success);

  // The learning thread gives up on a frame's TF after tf_timeout; one more
  // call after that, and its ~result counts the held-out frames as untracked.
  ros::WallDuration(1.0).sleep();
  const auto last = resultOfOneCall(camera, results, frames[0]);
  ASSERT_TRUE(last.has_value());
  EXPECT_TRUE(last->learning);
  EXPECT_GE(last->keyframes_added, 10u);  // the room's training loop moves more than 5 cm a frame
  EXPECT_GE(last->keyframes_learned, 2u);
  EXPECT_LE(last->keyframes_stored, 64u);
  EXPECT_GT(last->model_bytes, 0u);
  EXPECT_GT(last->keyframe_bytes, 0u);
  // The held-out frames had no TF: none of them was learned from.
  EXPECT_GE(last->frames_untracked, 1u);
  EXPECT_EQ(last->learning_error, "");
  // The jumps were refused (each offers a key frame), and they were jumps, not a new map.
  EXPECT_GE(last->slam_poses_refused, 3u);
  EXPECT_FALSE(last->learning_stopped);

  // ~save_model writes the set as one folder (one submap here) inside the
  // node's save_model_folder ($ROS_HOME/relocalizer here), named relatively
  // as a user names it; the answer names it absolutely. The manifest, the
  // model and its key frames load.
  namespace fs = std::filesystem;
  const std::string name = "relocalizer_learn_test_" + std::to_string(::getpid());
  const auto saved = saveAndReadFolder(name);
  ASSERT_TRUE(saved.has_value());
  EXPECT_EQ(fs::path(saved->path).filename().string(), name);
  ASSERT_EQ(saved->manifest.submaps.size(), 1u);
  const relocalizer::SubmapEntry& entry = saved->manifest.submaps[0];
  EXPECT_FALSE(entry.model.empty());
  auto key_frames = relocalizer::loadKeyFrames(saved->path + "/" + entry.keyframes);
  ASSERT_TRUE(key_frames.ok()) << key_frames.error();
  EXPECT_GE(key_frames->key_frames.size(), 10u);
  // An earlier save is ours to write again, named absolutely too.
  ASSERT_TRUE(saveAndReadFolder(saved->path).has_value());
  const fs::path root = fs::path(saved->path).parent_path();

  // Issue 38: any peer may call ~save_model, and the node often runs as
  // root. Nothing is written outside save_model_folder: not into an existing
  // folder (a stand-in for /etc/cron.d), not through `..`, not through a link
  // inside it; nor into a folder inside it that holds other files.
  const fs::path cron = "/tmp/" + name + "_cron.d";
  fs::create_directories(cron);
  std::ofstream(cron / "job") << "* * * * * root true\n";
  fs::create_directory_symlink(cron, root / (name + "_link"));
  relocalizer::SaveModel save;
  for (const std::string path : {cron.string(), (cron / "new").string(), "../" + name + "_x",
                                 name + "_link", name + "_link/new"}) {
    save.request.path = path;
    ASSERT_TRUE(ros::service::call("/relocalizer/save_model", save));
    EXPECT_FALSE(save.response.success) << path;
    EXPECT_TRUE(contains(save.response.message, "not inside the save folder " + root.string()))
        << save.response.message;
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(cron), fs::directory_iterator()), 1);
  fs::create_directories(root / (name + "_notes"));
  std::ofstream(root / (name + "_notes") / "notes.txt") << "mine\n";
  save.request.path = name + "_notes";
  ASSERT_TRUE(ros::service::call("/relocalizer/save_model", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_TRUE(contains(save.response.message, "holds files that are not a saved set"))
      << save.response.message;

  // Nor does it replace what is not a folder of ours (here a FIFO; as root,
  // /dev/null would do the same).
  const fs::path fifo = root / (name + ".fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  save.request.path = fifo.string();
  ASSERT_TRUE(ros::service::call("/relocalizer/save_model", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_TRUE(contains(save.response.message, fifo.string() + ": is not a folder"))
      << save.response.message;
  EXPECT_EQ(fs::status(fifo).type(), fs::file_type::fifo);
  save.request.path = "";
  ASSERT_TRUE(ros::service::call("/relocalizer/save_model", save));
  EXPECT_FALSE(save.response.success);
  EXPECT_TRUE(contains(save.response.message, "path is empty")) << save.response.message;
  for (const fs::path& made :
       {fs::path(saved->path), root / (name + "_link"), root / (name + "_notes"), fifo, cron})
    fs::remove_all(made);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_learn");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
