// replay.launch on the fixture bag: with process_all the node's answers must be
// the offline `evaluate` answers on the same frames, pose for pose.

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace fs = std::filesystem;

namespace {

std::vector<std::vector<double>> readPoses(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> row;
    for (double v; fields >> v;) row.push_back(v);
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json readJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(Replay, MatchesOfflineEvaluatePoseForPose) {
  std::string fixture;
  ASSERT_TRUE(ros::NodeHandle("~").getParam("fixture", fixture));
  const fs::path replay = fs::path(fixture) / "replay";
  const fs::path offline = fs::path(fixture) / "evaluate";
  // Output of an earlier run may still be there; this run's summary names its run_id.
  std::string run_id;
  ASSERT_TRUE(ros::param::get("/run_id", run_id));
  auto written_by_this_run = [&] {
    if (!fs::exists(replay / "errors.png")) return false;  // the last file written
    try {
      return readJson(replay / "summary.json").value("run_id", "") == run_id;
    } catch (const std::exception&) {
      return false;  // being written
    }
  };
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(120.0);
  while (!written_by_this_run() && ros::WallTime::now() < give_up) ros::WallDuration(0.2).sleep();
  ASSERT_TRUE(written_by_this_run()) << "the replay wrote no output in 120 s";
  ros::WallDuration(0.5).sleep();

  const auto replayed = readPoses(replay / "poses.txt");
  const auto evaluated = readPoses(offline / "poses.txt");
  ASSERT_EQ(replayed.size(), evaluated.size());
  ASSERT_EQ(replayed.size(), 20u);
  for (size_t i = 0; i < replayed.size(); ++i) {
    ASSERT_EQ(replayed[i].size(), 8u);
    for (size_t k = 0; k < 8; ++k)
      EXPECT_NEAR(replayed[i][k], evaluated[i][k], 1e-6) << "row " << i;
  }
  const auto a = readJson(replay / "summary.json");
  const auto b = readJson(offline / "summary.json");
  for (const char* key :
       {"frames", "frames_with_pose", "frames_without_pose", "within_5cm_5deg", "within_2cm_2deg",
        "wrong_answers", "median_translation_cm", "median_rotation_deg", "ate_rmse_cm"})
    // The replayed pose went through a quaternion message: equal to ~1e-12, not bitwise.
    EXPECT_NEAR(a.at(key).get<double>(), b.at(key).get<double>(), 1e-6) << key;
  EXPECT_EQ(a.at("node").at("frames_dropped"), 0);
  EXPECT_EQ(a.at("frames_without_result"), 0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay");
  return RUN_ALL_TESTS();
}
