#pragma once
// Readers for the public RGB-D relocalization datasets, so training,
// evaluation and synthesis tools see every dataset as the same list of
// RgbdFrames with camera-to-world ground truth.
//
// Layouts read (format names as accepted by parseDatasetFormat):
//  - 7-Scenes folder ("7scenes"): frame-XXXXXX.color.png|jpg, .depth.png
//    (16-bit millimetres, 0 and 65535 invalid), .pose.txt (4x4 camera-to-world);
//    optional camera-intrinsics.txt (3x3 K), else fx = fy = 585, cx 320, cy 240.
//    id = stamp = XXXXXX.
//  - 7-Scenes scene ("7scenes"): seq-XX/ folders, each a 7-Scenes folder, with
//    TrainSplit.txt / TestSplit.txt ("sequenceN" lines) for the train/test
//    split; camera-intrinsics.txt is looked for in the scene folder.
//    id = stamp = N * 1000 + XXXXXX (7-Scenes sequences have at most 1000
//    frames, so ids stay unique and readable: 3042 is frame 42 of seq-03).
//  - 12-Scenes / 4-Scenes ("12scenes"): data/frame-XXXXXX.color.jpg, .depth.png,
//    .pose.txt and info.txt (depth size, m_depthShift, depth intrinsics). The
//    colour is resampled to the depth resolution; poses holding inf or nan mark
//    frames without ground truth. id = stamp = XXXXXX.
//  - TUM RGB-D ("tum"): rgb.txt, depth.txt, optional groundtruth.txt. Depth is
//    associated to colour by nearest stamp within 0.02 s as TUM's associate.py;
//    ground truth is interpolated at the colour stamp. Depth 5000 units per
//    metre; intrinsics from the folder name (freiburg1/2/3 or fr1/2/3).
//    id = index in the associated list, stamp = colour timestamp.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "relocalizer/core/camera.h"
#include "relocalizer/core/expected.h"
#include "relocalizer/core/frame.h"
#include "relocalizer/core/pose.h"

namespace relocalizer {

// Both 7-Scenes values, when requested, mean "7-Scenes, layout detected":
// users say "7scenes" for a sequence folder and a scene alike, and the two are
// told apart by the seq-XX folders. Dataset::format() says which was found.
enum class DatasetFormat { Auto, SevenScenesFolder, SevenScenesScene, TwelveScenes, Tum };

// Command-line names, case-insensitive: "auto", "7scenes" (SevenScenesFolder,
// which as a request also opens scenes), "12scenes" or "4scenes" (same layout),
// "tum". Unknown names fail with the list of accepted ones.
Expected<DatasetFormat> parseDatasetFormat(const std::string& name);

// Human-readable name for summaries and messages ("7-Scenes folder", "TUM RGB-D").
std::string formatName(DatasetFormat format);

struct DatasetOptions {
  // Auto detects from the files present; an explicit format skips detection
  // and reports what its layout is missing.
  DatasetFormat format = DatasetFormat::Auto;
  // FrameSelection expression over frame ids ("" = all), e.g. "0-99,200-299".
  std::string frames;
  // "train", "test" or "all"; only 7-Scenes scenes have splits, and asking for
  // one elsewhere is an error rather than a silent "all".
  std::string split = "all";
  // Replaces the dataset's intrinsics (fx, fy, cx, cy) for recordings made with
  // a calibrated camera; width and height always come from the images.
  std::optional<CameraIntrinsics> intrinsics;
  // 7-Scenes colour is not registered to depth; its readers resample colour
  // onto the depth grid (registration.h) using colour-registration.txt or the
  // 7-Scenes Kinect calibration. false keeps colour as captured.
  bool register_colour = true;
};

namespace detail {
struct DatasetData;
}

// A dataset's frame list: paths, ids, stamps and ground truth are read at open
// time, so malformed pose and list files surface at once; images are read by
// load(), so opening a large dataset is quick and memory stays flat.
class Dataset {
 public:
  // Built by openDataset(); DatasetData is private to the library.
  explicit Dataset(std::unique_ptr<const detail::DatasetData> data);
  ~Dataset();
  Dataset(const Dataset&) = delete;
  Dataset& operator=(const Dataset&) = delete;

  // Number of selected frames; indices 0..size()-1 follow increasing id.
  size_t size() const;
  // Id of the i-th selected frame (see the layout notes above), for reports
  // that must name frames the way the dataset does. Throws std::out_of_range
  // for i >= size() (a programming error).
  int id(size_t i) const;
  // Seconds; the frame number for datasets without time. Throws like id().
  double stamp(size_t i) const;
  // Camera-to-world ground truth without reading images, for evaluation and
  // for choosing training frames. Throws like id().
  const std::optional<Pose>& groundTruth(size_t i) const;
  // Reads and converts the i-th frame's images. Thread-safe, so tools can load
  // frames in parallel; every failure (missing, unreadable or inconsistent
  // images, i out of range) is an Error naming the file.
  Expected<RgbdFrame> load(size_t i) const;

  // Depth camera intrinsics at the image size of the frames load() returns.
  const CameraIntrinsics& camera() const;
  // The layout actually read (never Auto).
  DatasetFormat format() const;
  // The path passed to openDataset(), without a trailing separator.
  const std::string& root() const;
  // Several lines for logs and tool output: format, root, frames selected (as
  // ranges), image size, intrinsics and their source, frames with ground truth
  // and the ground-truth path length in metres, so a wrong folder, selection or
  // unit shows before a long run.
  std::string summary() const;

 private:
  std::unique_ptr<const detail::DatasetData> data_;
};

// Opens the dataset at `path` (a folder). Fails, never throws, with a message
// naming the file, line and expectation when the layout is not recognised, a
// list or pose file is missing or malformed, or the selection matches no frame.
Expected<std::unique_ptr<Dataset>> openDataset(const std::string& path,
                                               const DatasetOptions& options = {});

}  // namespace relocalizer
