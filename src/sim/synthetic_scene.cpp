// Writing a synthetic room out as a 7-Scenes style dataset.

#include "relocalizer/sim/synthetic_scene.h"

#include <tbb/parallel_for.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset_files.h"
#include "relocalizer/core/progress.h"

namespace relocalizer {
namespace {

namespace fs = std::filesystem;
using synthetic::frameStem;
using synthetic::writeText;

constexpr int kMaxFrames = 1000000;
constexpr int kMaxImageSide = 4096;

// Depth as a colour map over the sensor's range; invalid pixels black.
cv::Mat colouriseDepth(const cv::Mat& depth) {
  cv::Mat scaled(depth.size(), CV_8UC1);
  cv::Mat invalid(depth.size(), CV_8UC1);
  const double lo = KinectDepthModel::kMinDepth, hi = KinectDepthModel::kMaxDepth;
  for (int v = 0; v < depth.rows; ++v) {
    const float* d = depth.ptr<float>(v);
    uint8_t* s = scaled.ptr<uint8_t>(v);
    uint8_t* bad = invalid.ptr<uint8_t>(v);
    for (int u = 0; u < depth.cols; ++u) {
      const bool valid = std::isfinite(d[u]);
      bad[u] = valid ? 0 : 255;
      s[u] = valid ? cv::saturate_cast<uint8_t>((d[u] - lo) / (hi - lo) * 255.0) : 0;
    }
  }
  cv::Mat coloured;
  cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
  coloured.setTo(cv::Scalar::all(0), invalid);
  return coloured;
}

struct SheetEntry {
  std::string label;
  cv::Mat colour, depth;
};

// Rows of (colour, depth) pairs, two pairs per row, tiles 320 px wide.
cv::Mat contactSheet(const std::vector<SheetEntry>& entries, const CameraIntrinsics& camera) {
  const int tile_w = 320;
  const int tile_h =
      std::max(1, static_cast<int>(std::lround(320.0 * camera.height / camera.width)));
  const int pairs_per_row = 2;
  const int rows = static_cast<int>((entries.size() + pairs_per_row - 1) / pairs_per_row);
  cv::Mat sheet(std::max(rows, 1) * tile_h, 2 * pairs_per_row * tile_w, CV_8UC3,
                cv::Scalar::all(32));
  for (size_t i = 0; i < entries.size(); ++i) {
    const int row = static_cast<int>(i) / pairs_per_row, col = static_cast<int>(i) % pairs_per_row;
    const cv::Rect colour_rect(2 * col * tile_w, row * tile_h, tile_w, tile_h);
    const cv::Rect depth_rect((2 * col + 1) * tile_w, row * tile_h, tile_w, tile_h);
    const int interpolation = entries[i].colour.cols > tile_w ? cv::INTER_AREA : cv::INTER_NEAREST;
    cv::resize(entries[i].colour, sheet(colour_rect), colour_rect.size(), 0, 0, interpolation);
    // Nearest neighbour keeps holes black instead of smearing them.
    cv::resize(colouriseDepth(entries[i].depth), sheet(depth_rect), depth_rect.size(), 0, 0,
               cv::INTER_NEAREST);
    const cv::Point origin(colour_rect.x + 6, colour_rect.y + 18);
    cv::putText(sheet, entries[i].label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar::all(0),
                3, cv::LINE_AA);
    cv::putText(sheet, entries[i].label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar::all(255), 1, cv::LINE_AA);
  }
  return sheet;
}

// A few frames spread over a sequence.
std::vector<int> sheetFrames(int frames, int wanted) {
  std::vector<int> picked;
  for (int i = 0; i < std::min(frames, wanted); ++i)
    picked.push_back(
        static_cast<int>(static_cast<long long>(i) * frames / std::min(frames, wanted)));
  return picked;
}

nlohmann::ordered_json changesJson(const SceneChanges& changes) {
  return {{"people", changes.people},
          {"moved_furniture", changes.moved_furniture},
          {"removed_objects", changes.removed_objects},
          {"added_objects", changes.added_objects},
          {"lamp", lampChangeName(changes.lamp)}};
}

}  // namespace

bool SceneChanges::any() const {
  return people > 0 || moved_furniture > 0 || removed_objects > 0 || added_objects > 0 ||
         lamp != LampChange::kNone;
}

std::string SceneChanges::validationError() const {
  const std::pair<const char*, int> counts[] = {{"--test-people", people},
                                                {"--test-moved-furniture", moved_furniture},
                                                {"--test-removed-objects", removed_objects},
                                                {"--test-added-objects", added_objects}};
  const int most[] = {kMaxPeople, kMaxPieces, kMaxObjects, kMaxObjects};
  for (int i = 0; i < 4; ++i)
    if (counts[i].second < 0 || counts[i].second > most[i])
      return std::string(counts[i].first) + " must be from 0 to " + std::to_string(most[i]) +
             ", got " + std::to_string(counts[i].second);
  if (lamp != LampChange::kNone && lamp != LampChange::kOff && lamp != LampChange::kOn)
    return "--test-lamp must be none, off or on";
  return {};
}

std::string lampChangeName(LampChange lamp) {
  switch (lamp) {
    case LampChange::kOff:
      return "off";
    case LampChange::kOn:
      return "on";
    default:
      return "none";
  }
}

std::optional<LampChange> lampChangeFromName(const std::string& name) {
  for (const LampChange lamp : {LampChange::kNone, LampChange::kOff, LampChange::kOn})
    if (lampChangeName(lamp) == name) return lamp;
  return std::nullopt;
}

std::string SyntheticSceneOptions::validationError() const {
  if (train_frames < 1 || train_frames > kMaxFrames)
    return "train_frames must be in [1, " + std::to_string(kMaxFrames) + "], got " +
           std::to_string(train_frames);
  if (test_frames < 0 || test_frames > kMaxFrames)
    return "test_frames must be in [0, " + std::to_string(kMaxFrames) + "], got " +
           std::to_string(test_frames);
  const std::string camera_error = camera.validationError();
  if (!camera_error.empty()) return "camera: " + camera_error;
  const std::string changes_error = test_changes.validationError();
  if (!changes_error.empty()) return changes_error;
  if (camera.width > kMaxImageSide || camera.height > kMaxImageSide)
    return "image size must be at most " + std::to_string(kMaxImageSide) + " pixels a side, got " +
           std::to_string(camera.width) + "x" + std::to_string(camera.height);
  return {};
}

Status writeSyntheticScene(const std::string& output_dir, const SyntheticSceneOptions& options) {
  const std::string invalid = options.validationError();
  if (!invalid.empty()) return makeError("synthetic scene options: " + invalid);
  if (output_dir.empty()) return makeError("no output folder given");
  const fs::path root(output_dir);
  const fs::path split_dirs[2] = {root / "train", root / "test"};
  for (const fs::path& dir : split_dirs) {
    std::error_code error;
    fs::create_directories(dir, error);
    if (error) return makeError("cannot create " + dir.string() + ": " + error.message());
    const Status written = synthetic::writeCameraFiles(dir, options.camera);
    if (!written) return written;
  }

  const SyntheticRoom room(
      RoomRecipe{options.appearance_seed.value_or(options.seed), options.seed});
  // The world as it is when the test frames are taken.
  const SyntheticRoom test_room = room.changed(options.test_changes);
  const SyntheticRoom* split_rooms[2] = {&room, &test_room};
  const SyntheticTrajectories paths = room.trajectories(options.train_frames, options.test_frames);
  const std::vector<Pose>* split_paths[2] = {&paths.train, &paths.test};

  // Rewriting a folder with fewer frames must not leave the old run's tail
  // behind to be read as part of the new dataset.
  for (int split = 0; split < 2; ++split) {
    const int frames = static_cast<int>(split_paths[split]->size());
    std::vector<fs::path> stale;
    for (const auto& entry : fs::directory_iterator(split_dirs[split])) {
      const std::string name = entry.path().filename().string();
      int index = -1;
      char suffix[16] = {};
      if (std::sscanf(name.c_str(), "frame-%6d.%15s", &index, suffix) == 2 && index >= frames &&
          (std::string(suffix) == "color.png" || std::string(suffix) == "depth.png" ||
           std::string(suffix) == "pose.txt"))
        stale.push_back(entry.path());
    }
    for (const fs::path& path : stale) {
      std::error_code error;
      fs::remove(path, error);
      if (error) return makeError("cannot remove stale " + path.string() + ": " + error.message());
    }
  }

  struct Job {
    int split, index;
  };
  std::vector<Job> jobs;
  for (int split = 0; split < 2; ++split)
    for (int i = 0; i < static_cast<int>(split_paths[split]->size()); ++i)
      jobs.push_back({split, i});

  // Three frames of each split on the contact sheet, training first.
  std::vector<std::pair<int, int>> sheet_keys;
  for (int split = 0; split < 2; ++split)
    for (const int i : sheetFrames(static_cast<int>(split_paths[split]->size()), 3))
      sheet_keys.emplace_back(split, i);
  std::vector<SheetEntry> sheet(sheet_keys.size());

  std::vector<std::string> errors(jobs.size());
  ProgressBar progress("synthesize", jobs.size());
  const std::vector<int> png_params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  tbb::parallel_for(size_t{0}, jobs.size(), [&](size_t j) {
    const Job job = jobs[j];
    const std::vector<Pose>& path = *split_paths[job.split];
    RenderEffects effects;
    effects.illumination_change = options.illumination_change;
    effects.moving_objects = options.moving_objects;
    if (options.motion_blur) effects.motion_blur_poses = motionBlurPoses(path, job.index);
    // Time runs on from training into test, as if recorded one after the other.
    const int time = job.split == 0 ? job.index : options.train_frames + job.index;
    const RgbdFrame frame =
        split_rooms[job.split]->render(path[job.index], options.camera, time, effects);
    const Status written = synthetic::writeFrameFiles(
        (split_dirs[job.split] / frameStem(job.index)).string(), frame, path[job.index]);
    if (!written) errors[j] = written.error();
    for (size_t s = 0; s < sheet_keys.size(); ++s)
      if (sheet_keys[s] == std::make_pair(job.split, job.index))
        sheet[s] = {(job.split == 0 ? "train " : "test ") + frameStem(job.index), frame.colour,
                    frame.depth};
    progress.advance();
  });
  progress.finish();
  for (const std::string& error : errors)
    if (!error.empty()) return makeError(error);

  const fs::path sheet_path = root / "contact_sheet.png";
  if (!cv::imwrite(sheet_path.string(), contactSheet(sheet, options.camera), png_params))
    return makeError("cannot write " + sheet_path.string());

  const Eigen::AlignedBox3d bounds = room.bounds();
  const CameraIntrinsics& k = options.camera;
  nlohmann::ordered_json json;
  json["generator"] = "relocalizer synthetic room";
  json["format_version"] = 1;
  json["seed"] = options.seed;
  if (room.appearanceSeed() != room.seed()) json["appearance_seed"] = room.appearanceSeed();
  json["train_frames"] = options.train_frames;
  json["test_frames"] = options.test_frames;
  json["camera"] = {{"fx", k.fx}, {"fy", k.fy},       {"cx", k.cx},
                    {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
  json["effects"] = {{"motion_blur", options.motion_blur},
                     {"illumination_change", options.illumination_change},
                     {"moving_objects", options.moving_objects}};
  // As asked, and as made (fewer where the room had no place for more).
  json["test_changes"] = changesJson(options.test_changes);
  json["test_changes"]["made"] = changesJson(test_room.changes());
  json["test_changes"]["test_room_boxes"] = test_room.boxCount();
  json["depth"] = {{"units_per_metre", 1000},
                   {"invalid_value", 0},
                   {"model",
                    "Kinect v1: 1/8 px disparity quantisation at fB = 0.075 m * 585 px, "
                    "sigma = 0.0012 + 0.0019 (z - 0.4)^2 m, holes at depth edges and on "
                    "dark or transparent surfaces"},
                   {"min_metres", KinectDepthModel::kMinDepth},
                   {"max_metres", KinectDepthModel::kMaxDepth}};
  json["poses"] = "camera-to-world 4x4; camera x right, y down, z forward; world z up, floor z = 0";
  json["test_time_offset"] = options.train_frames;
  json["room"] = {{"min", {bounds.min().x(), bounds.min().y(), bounds.min().z()}},
                  {"max", {bounds.max().x(), bounds.max().y(), bounds.max().z()}},
                  {"boxes", room.boxCount()}};
  if (!writeText(root / "scene.json", json.dump(2) + "\n"))
    return makeError("cannot write " + (root / "scene.json").string());
  return okStatus();
}

}  // namespace relocalizer
