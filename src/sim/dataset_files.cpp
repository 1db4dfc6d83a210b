// The files of a synthetic 7-Scenes folder.

#include "dataset_files.h"

#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <vector>

namespace relocalizer {
namespace synthetic {

namespace fs = std::filesystem;

std::string frameStem(int index) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "frame-%06d", index);
  return buffer;
}

bool writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  return static_cast<bool>(out);
}

std::string poseText(const Pose& pose) {
  const Eigen::Matrix4d m = pose.matrix();
  std::string text;
  char buffer[64];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buffer, sizeof buffer, c < 3 ? "%.9e\t" : "%.9e\n", m(r, c));
      text += buffer;
    }
  }
  return text;
}

namespace {

std::string intrinsicsText(const CameraIntrinsics& k) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "%.9e\t%.9e\t%.9e\n%.9e\t%.9e\t%.9e\n%.9e\t%.9e\t%.9e\n",
                k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0);
  return buffer;
}

}  // namespace

Status writeCameraFiles(const fs::path& dir, const CameraIntrinsics& camera) {
  if (!writeText(dir / "camera-intrinsics.txt", intrinsicsText(camera)))
    return makeError("cannot write " + (dir / "camera-intrinsics.txt").string());
  // Tells the 7-Scenes reader not to apply the real Kinect's colour-to-depth
  // registration: the renderer's colour and depth share one camera.
  if (!writeText(dir / "colour-registration.txt", "registered\n"))
    return makeError("cannot write " + (dir / "colour-registration.txt").string());
  return okStatus();
}

Status writeFrameFiles(const std::string& stem, const RgbdFrame& frame, const Pose& pose) {
  static const std::vector<int> kPngParams = {cv::IMWRITE_PNG_COMPRESSION, 3};
  const std::string colour_path = stem + ".color.png";
  const std::string depth_path = stem + ".depth.png";
  const std::string pose_path = stem + ".pose.txt";
  if (!cv::imwrite(colour_path, frame.colour, kPngParams))
    return makeError("cannot write " + colour_path);
  if (!cv::imwrite(depth_path, depthToMillimetres(frame.depth), kPngParams))
    return makeError("cannot write " + depth_path);
  if (!writeText(pose_path, poseText(pose))) return makeError("cannot write " + pose_path);
  return okStatus();
}

}  // namespace synthetic
}  // namespace relocalizer
