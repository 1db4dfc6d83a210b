#pragma once
// The small text files the dataset readers share (dataset_*.cpp, TUM
// trajectories): lines, numbers, pose and intrinsics files. Not installed.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/pose.h"

namespace relocalizer::detail {

namespace fs = std::filesystem;

// Lines of a text file, without line terminators ("\r\n" too).
Expected<std::vector<std::string>> readLines(const fs::path& file);

// True for a line of only blanks or a '#' comment (TUM's lists and trajectories).
bool isCommentOrBlank(const std::string& line);

// Whitespace-separated numbers of one line; accepts inf and nan so callers
// decide what they mean. Errors read "<file>: line <n>: '<token>' is not a number".
Expected<std::vector<double>> parseNumbers(const std::string& line, const fs::path& file,
                                           int line_number);

// How a reader treats non-finite pose entries.
enum class NonFinitePose {
  Error,          // 7-Scenes: a corrupt file
  NoGroundTruth,  // 12-Scenes: tracking lost for that frame
};

// A 4x4 camera-to-world matrix in a file of four lines of four numbers.
Expected<std::optional<Pose>> readPoseFile(const fs::path& file, NonFinitePose non_finite);

// A 3x3 K (7-Scenes camera-intrinsics.txt); width and height are left alone.
Expected<CameraIntrinsics> readIntrinsicsFile(const fs::path& file);

}  // namespace relocalizer::detail
