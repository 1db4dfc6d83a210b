#pragma once
// The files of a 7-Scenes folder as the synthetic datasets write them (one
// room's train/ and test/, a building's walk/), so both write them alike.
// Private to the sim module.

#include <filesystem>
#include <string>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {
namespace synthetic {

// "frame-000012": the stem of frame 12's files.
std::string frameStem(int index);
bool writeText(const std::filesystem::path& path, const std::string& text);
// A 4x4 camera-to-world matrix as 7-Scenes writes it.
std::string poseText(const Pose& pose);
// camera-intrinsics.txt and colour-registration.txt in `dir`.
Status writeCameraFiles(const std::filesystem::path& dir, const CameraIntrinsics& camera);
// stem.color.png, stem.depth.png (millimetres) and stem.pose.txt.
Status writeFrameFiles(const std::string& stem, const RgbdFrame& frame, const Pose& pose);

}  // namespace synthetic
}  // namespace relocalizer
