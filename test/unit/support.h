#pragma once
// Shared helpers for the core unit tests: temporary folders and the location of
// the real-data folder beside the checkout.

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "relocalizer/core/frame.h"
#include "relocalizer/forest/training.h"
#include "relocalizer/online/online_learner.h"
#include "relocalizer/relocalize/relocalizer.h"

namespace relocalizer::testing {

// The small forests and sample counts that tests train a generated room's
// model with (320x240 frames, a few dozen training frames; seconds to train).
TrainingParams smallRoomTraining();
RelocalizerParams smallRoomRelocalizer();
// The same for a room learned online from key frames: forests a retrain of 20
// key frames grows in a few seconds, and a relocalizer to match.
LearningParams onlineRoomLearning();
RelocalizerParams onlineRoomRelocalizer();

// A generated room (seed 7) at 320x240: every fourth frame of an 80-frame
// training arc (what the 5 cm / 5 deg key-frame rule keeps: 20 key frames, ids
// 0, 4, ...) and 20 test frames (ids 100-119) beside the arc. The walk the
// submap tests learn.
struct RoomWalk {
  std::vector<RgbdFrame> learn, test;
};
RoomWalk submapRoomWalk();

// An answer within 5 cm / 5 deg of the frame's ground truth (eval/metrics.h's rule).
bool correctPose(const Relocalization& answer, const RgbdFrame& frame);

// Same size, type and bytes (NaN depth holes included).
bool sameImage(const cv::Mat& a, const cv::Mat& b);

// A fresh folder under the system temp dir, removed when the object dies.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "relocalizer_test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

// ../shared/data/7scenes-redkitchen-dev beside the checkout, or empty when absent.
std::string redkitchenDir();

// A file's bytes ("" when it cannot be read).
std::string readBytes(const std::filesystem::path& path);
// Relative path -> bytes of every file below `root`.
std::map<std::string, std::string> readTree(const std::filesystem::path& root);

// Runs a tool of this build (`tool` in the devel space's lib/relocalizer) with
// `arguments` (shell words); its standard error goes to `stderr_file` and its
// standard output to `stdout_file` (the same file: both, in order). Returns the
// exit status, -1 when it did not exit.
int runTool(const std::string& tool, const std::string& arguments,
            const std::filesystem::path& stderr_file,
            const std::filesystem::path& stdout_file = "/dev/null");

}  // namespace relocalizer::testing

// Real-data tests say clearly why they did not run.
#define RELOCALIZER_REQUIRE_REDKITCHEN(dir_variable)                                   \
  const std::string dir_variable = ::relocalizer::testing::redkitchenDir();            \
  if (dir_variable.empty())                                                            \
  GTEST_SKIP() << "real-data check skipped: ../shared/data/7scenes-redkitchen-dev is " \
                  "absent beside the checkout"
