// Learn mode with submaps (issue 26): the fixture room's training loop, played
// with its poses on TF as SLAM publishes them, is learned with a small cap per
// submap, so the node cuts it into several submaps. Each is a place of the
// group `learned` in map; once TF stops, frames of the loop and held-out
// frames are answered in map by a submap, within 5 cm / 5 deg. Frozen submaps
// are written into the save_on_exit folder as they freeze; ~save_model writes
// the whole set as a folder.

#include <relocalizer/ListPlaces.h>
#include <relocalizer/SaveModel.h>
#include <relocalizer/UnloadPlace.h>

#include <unistd.h>

#include <filesystem>
#include <set>

#include "learn_bag.h"
#include "node_test_support.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/submap_folder.h"

using namespace relocalizer_test;

TEST(LearnSubmaps, ALoopLearnedInSubmapsIsAnsweredInMapByItsSubmaps) {
  const auto started = std::filesystem::file_time_type::clock::now();
  Listener<ResultMsg> results("/relocalizer/result", 1000);
  CameraPublisher camera;
  ASSERT_GE(playLearnBag(camera), 50);

  // The first key frame of the loop (submap 0's first) and held-out frames.
  std::vector<FrameMessages> frames = {loadFixtureFrames("scene", "train")[0]};
  const std::vector<FrameMessages> test = loadFixtureFrames();
  for (size_t i = 0; i < test.size(); i += 5) frames.push_back(test[i]);
  std::set<std::string> answering;
  for (size_t i = 0; i < frames.size(); ++i) {
    const relocalizer::Relocalize::Response r =
        relocalizeUntilAnswered(camera, frames[i], ros::WallTime::now() + ros::WallDuration(60.0));
    ASSERT_TRUE(r.success) << "frame " << i << ": " << r.message;
    EXPECT_LT(translationError(r.pose.pose.pose, frames[i].truth), 0.05) << "frame " << i;
    EXPECT_LT(rotationError(r.pose.pose.pose, frames[i].truth), 5.0) << "frame " << i;
    EXPECT_EQ(r.pose.header.frame_id, "map") << "frame " << i;
    EXPECT_EQ(r.place.rfind("learned/", 0), 0u) << "frame " << i << ": " << r.place;
    if (i == 0) {
      EXPECT_EQ(r.place, "learned/0") << "the loop's first key frame";
    }
    answering.insert(r.place);
  }
  std::printf("answering submaps:");
  for (const std::string& place : answering) std::printf(" %s", place.c_str());
  std::printf("\n");

  // ~result: several submaps, none over the cap; the listing has one place each,
  // all of the group `learned` in map, and none of them can be unloaded.
  const auto last = resultOfOneCall(camera, results, frames[0]);
  ASSERT_TRUE(last.has_value());
  EXPECT_TRUE(last->learning);
  EXPECT_GE(last->submaps, 2u);
  EXPECT_LE(last->keyframes_stored, 8u);
  // Key frames are counted once, seeds and all: more than one submap holds.
  EXPECT_GT(last->keyframes_added, 8u);
  EXPECT_EQ(last->learning_error, "");
  std::printf("~result: %u submaps, %u key frames added, %u covered, %u frames skipped\n",
              last->submaps, last->keyframes_added, last->keyframes_covered,
              last->learning_frames_skipped);
  relocalizer::ListPlaces listing;
  ASSERT_TRUE(ros::service::call("/relocalizer/list_places", listing));
  ASSERT_GE(listing.response.places.size(), 2u);
  ASSERT_LE(listing.response.places.size(), last->submaps);
  for (size_t i = 0; i < listing.response.places.size(); ++i) {
    const relocalizer::PlaceInfo& place = listing.response.places[i];
    EXPECT_EQ(place.name, "learned/" + std::to_string(i));
    EXPECT_EQ(place.group, "learned");
    EXPECT_EQ(place.map_frame, "map");
    EXPECT_EQ(place.model, "");
    EXPECT_LE(place.training_frames, 8u) << place.name;
  }
  relocalizer::UnloadPlace unload;
  unload.request.name = "learned/0";
  ASSERT_TRUE(ros::service::call("/relocalizer/unload_place", unload));
  EXPECT_FALSE(unload.response.success);
  EXPECT_TRUE(contains(unload.response.message, "is a learned place")) << unload.response.message;

  // The frozen submaps were written into save_on_exit as they froze, before any save.
  std::string exit_folder;
  ASSERT_TRUE(ros::param::get("~exit_folder", exit_folder));
  const std::string exit_manifest = exit_folder + "/manifest.json";
  // A freeze is a last retrain on the node's freeze thread: on a slow machine
  // the first may still be running when the answers above came.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(60.0);
  std::error_code ec;
  while ((!std::filesystem::is_regular_file(exit_manifest) ||
          std::filesystem::last_write_time(exit_manifest, ec) < started) &&
         ros::WallTime::now() < give_up)
    ros::WallDuration(0.2).sleep();
  ASSERT_TRUE(std::filesystem::is_regular_file(exit_manifest)) << exit_manifest;
  EXPECT_GE(std::filesystem::last_write_time(exit_manifest), started)
      << "a stale " << exit_manifest;
  auto frozen = relocalizer::readSubmapManifest(exit_folder);
  ASSERT_TRUE(frozen.ok()) << frozen.error();
  EXPECT_GE(frozen->submaps.size(), 1u);
  for (const relocalizer::SubmapEntry& entry : frozen->submaps) {
    EXPECT_TRUE(entry.frozen) << entry.name;
    EXPECT_TRUE(relocalizer::loadModel(exit_folder + "/" + entry.model).ok()) << entry.model;
  }

  // ~save_model writes the whole set as one folder: the manifest names every
  // submap, and each named model file loads.
  const auto saved = saveAndReadFolder("relocalizer_submaps_test_" + std::to_string(::getpid()));
  ASSERT_TRUE(saved.has_value());
  EXPECT_GE(saved->manifest.submaps.size(), 2u);
  EXPECT_EQ(saved->manifest.place_name, "learned");
  EXPECT_EQ(saved->manifest.map_frame, "map");
  std::filesystem::remove_all(saved->path);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_learn_submaps");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
