#pragma once
// Shared between the dataset readers (dataset_*.cpp); not installed.

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"
#include "relocalizer/data/dataset.h"
#include "relocalizer/data/frame_selection.h"
#include "relocalizer/data/registration.h"

#include "dataset_text_files.h"

namespace relocalizer::detail {

namespace fs = std::filesystem;

struct DatasetFrame {
  int id = -1;
  double stamp = 0.0;
  std::optional<Pose> ground_truth;
  std::string colour_path;
  std::string depth_path;
};

struct DatasetData {
  DatasetFormat format = DatasetFormat::Auto;
  std::string root;
  CameraIntrinsics camera;
  std::string camera_source;  // where the intrinsics came from, for summary()
  double depth_units_per_metre = 1000.0;
  // 12-Scenes colour is larger than its depth; other datasets must match.
  bool resample_colour = false;
  std::optional<cv::Size> colour_size;  // when known to differ from depth
  std::string selection = "all";        // FrameSelection::str()
  std::vector<int> all_ids;             // before selection, for messages
  std::vector<DatasetFrame> frames;     // selected, increasing id
  // Whether camera.width/height are known (12-Scenes: from info.txt);
  // otherwise openDataset() reads them from the first frame's depth.
  bool camera_size_known = false;
  // Applied to every loaded colour image (7-Scenes: colour is not registered).
  ColourRegistration registration;
  std::string registration_source = "none (colour already registered to depth)";
};

// What a reader needs beyond the folder.
struct ReaderInput {
  fs::path root;
  FrameSelection selection;
  std::string split = "all";
};

Expected<DatasetData> readSevenScenesFolder(const ReaderInput& input);
Expected<DatasetData> readSevenScenesScene(const ReaderInput& input);
Expected<DatasetData> readTwelveScenes(const ReaderInput& input);
Expected<DatasetData> readTum(const ReaderInput& input);

// ---- helpers shared by the readers (their text files: dataset_text_files.h) ---

// The frame files of one 7-Scenes style folder (also 12-Scenes data/), read
// into `out` for selected frame numbers. `id_offset` is added to the frame
// number to make the id (7-Scenes scenes); `max_frame_number` bounds the frame
// number so offset ids stay unique (-1: no bound). Fails on an empty folder.
Status readFrameFolder(const fs::path& dir, const FrameSelection& selection, int id_offset,
                       int max_frame_number, NonFinitePose non_finite, DatasetData& out);

// "<dir>: no such folder" / "not a folder", or empty.
std::string folderProblem(const fs::path& dir);

}  // namespace relocalizer::detail
