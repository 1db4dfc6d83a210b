// 7-Scenes folders and scenes; the frame-folder reader is shared with 12-Scenes,
// whose data/ folder uses the same file names.

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "dataset_internal.h"

namespace relocalizer::detail {
namespace {

struct FrameFiles {
  std::string stem;  // "frame-000012", as written, to name missing siblings
  std::string colour_png, colour_jpg, depth, pose;
};

// Leading decimal digits of `text` from `pos` as a non-negative int; false when
// there are none or they overflow. `end` receives the position after them.
bool parseDigits(const std::string& text, size_t pos, int& value, size_t& end) {
  end = pos;
  while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
  if (end == pos) return false;
  const auto [ptr, ec] = std::from_chars(text.data() + pos, text.data() + end, value);
  return ec == std::errc() && ptr == text.data() + end;
}

Expected<std::map<int, FrameFiles>> listFrameFiles(const fs::path& dir) {
  std::map<int, FrameFiles> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("frame-", 0) != 0) continue;
    int number = 0;
    size_t digits_end = 0;
    if (!parseDigits(name, 6, number, digits_end)) continue;
    std::error_code type_ec;
    if (!it->is_regular_file(type_ec)) continue;
    const std::string suffix = name.substr(digits_end);
    FrameFiles& frame = files[number];
    frame.stem = name.substr(0, digits_end);
    const std::string path = it->path().string();
    if (suffix == ".color.png")
      frame.colour_png = path;
    else if (suffix == ".color.jpg")
      frame.colour_jpg = path;
    else if (suffix == ".depth.png")
      frame.depth = path;
    else if (suffix == ".pose.txt")
      frame.pose = path;
  }
  if (ec) return makeError(dir.string() + ": cannot be listed: " + ec.message());
  // Numbers seen only in unrelated files (frame-000001.notes.txt) are not frames.
  for (auto it = files.begin(); it != files.end();) {
    const FrameFiles& f = it->second;
    if (f.colour_png.empty() && f.colour_jpg.empty() && f.depth.empty() && f.pose.empty())
      it = files.erase(it);
    else
      ++it;
  }
  return files;
}

}  // namespace

Status readFrameFolder(const fs::path& dir, const FrameSelection& selection, int id_offset,
                       int max_frame_number, NonFinitePose non_finite, DatasetData& out) {
  auto listed = listFrameFiles(dir);
  if (!listed) return makeError(listed.error());
  if (listed->empty())
    return makeError("no frames found in " + dir.string() +
                     ": expected frame-XXXXXX.color.png|jpg / .depth.png / .pose.txt");

  // A folder without any pose file is a query set; one missing among many is
  // a broken copy.
  bool any_pose = false;
  for (const auto& [number, files] : *listed) any_pose = any_pose || !files.pose.empty();

  for (const auto& [number, files] : *listed) {
    const std::string stem = (dir / files.stem).string();
    if (max_frame_number >= 0 && number > max_frame_number)
      return makeError(stem + ": frame number " + std::to_string(number) + " is above " +
                       std::to_string(max_frame_number) +
                       ", so ids sequence * 1000 + frame would collide");
    const int id = id_offset + number;
    out.all_ids.push_back(id);
    if (!selection.contains(id)) continue;

    DatasetFrame frame;
    frame.id = id;
    frame.stamp = id;
    frame.colour_path = !files.colour_png.empty() ? files.colour_png : files.colour_jpg;
    frame.depth_path = files.depth;
    const std::string present = !files.pose.empty()    ? files.pose
                                : !files.depth.empty() ? files.depth
                                                       : frame.colour_path;
    if (frame.colour_path.empty())
      return makeError(stem + ".color.png|jpg: missing (" + present + " exists)");
    if (frame.depth_path.empty())
      return makeError(stem + ".depth.png: missing (" + present + " exists)");
    if (files.pose.empty()) {
      if (any_pose)
        return makeError(stem + ".pose.txt: missing (other frames in " + dir.string() +
                         " have poses)");
    } else {
      auto pose = readPoseFile(files.pose, non_finite);
      if (!pose) return makeError(pose.error());
      frame.ground_truth = std::move(*pose);
    }
    out.frames.push_back(std::move(frame));
  }
  return okStatus();
}

namespace {

// colour-registration.txt when present: the word "registered" (colour already
// matches depth, as synthesize writes) or one line "fx fy cx cy tx ty tz" (the
// colour camera's intrinsics and its origin in depth-camera coordinates).
// Without it, the 7-Scenes Kinect calibration: 7-Scenes colour is not
// registered to depth.
Status readColourRegistration(const fs::path& root, DatasetData& data) {
  const fs::path file = root / "colour-registration.txt";
  std::error_code ec;
  if (!fs::exists(file, ec)) {
    data.registration = ColourRegistration::sevenScenesKinect();
    data.registration_source = "7-Scenes Kinect calibration (no colour-registration.txt)";
    return okStatus();
  }
  auto lines = readLines(file);
  if (!lines) return makeError(lines.error());
  for (size_t i = 0; i < lines->size(); ++i) {
    std::string line = (*lines)[i];
    line.erase(0, line.find_first_not_of(" \t"));
    line.erase(line.find_last_not_of(" \t") + 1);
    if (line.empty() || line[0] == '#') continue;
    if (line == "registered") {
      data.registration = ColourRegistration{};
      data.registration_source = "none: " + file.string() + " says colour is registered";
      return okStatus();
    }
    auto numbers = parseNumbers(line, file, static_cast<int>(i + 1));
    if (!numbers) return makeError(numbers.error());
    if (numbers->size() != 7)
      return makeError(file.string() + ": line " + std::to_string(i + 1) +
                       ": expected 'registered' or 7 numbers (fx fy cx cy tx ty tz), got " +
                       std::to_string(numbers->size()));
    const auto& n = *numbers;
    for (double value : n)
      if (!std::isfinite(value))
        return makeError(file.string() + ": line " + std::to_string(i + 1) +
                         ": every number must be finite");
    if (!(n[0] > 0 && n[1] > 0))
      return makeError(file.string() + ": line " + std::to_string(i + 1) +
                       ": colour focal lengths must be positive");
    data.registration.fx = n[0];
    data.registration.fy = n[1];
    data.registration.cx = n[2];
    data.registration.cy = n[3];
    data.registration.depth_to_colour = Eigen::Vector3d(n[4], n[5], n[6]);
    data.registration_source = file.string();
    return okStatus();
  }
  return makeError(file.string() + ": empty; expected 'registered' or 'fx fy cx cy tx ty tz'");
}

// camera-intrinsics.txt when present (the redkitchen-dev copy has one), else
// the Kinect values the 7-Scenes paper gives.
Status readSevenScenesIntrinsics(const fs::path& root, DatasetData& data) {
  const fs::path file = root / "camera-intrinsics.txt";
  std::error_code ec;
  if (fs::exists(file, ec)) {
    auto camera = readIntrinsicsFile(file);
    if (!camera) return makeError(camera.error());
    data.camera = *camera;
    data.camera_source = file.string();
  } else {
    data.camera = CameraIntrinsics::kinectDefault();
    data.camera_source = "7-Scenes Kinect default; no camera-intrinsics.txt";
  }
  return readColourRegistration(root, data);
}

std::string sequenceFolderName(int number) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "seq-%02d", number);
  return buffer;
}

}  // namespace

Expected<DatasetData> readSevenScenesFolder(const ReaderInput& input) {
  DatasetData data;
  data.depth_units_per_metre = 1000.0;
  if (auto status = readSevenScenesIntrinsics(input.root, data); !status)
    return makeError(status.error());
  if (auto status = readFrameFolder(input.root, input.selection, 0, -1, NonFinitePose::Error, data);
      !status)
    return makeError(status.error());
  return data;
}

Expected<DatasetData> readSevenScenesScene(const ReaderInput& input) {
  // Sequence number -> folder, from names like seq-01.
  std::map<int, fs::path> sequences;
  std::error_code ec;
  for (fs::directory_iterator it(input.root, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    int number = 0;
    size_t digits_end = 0;
    std::error_code type_ec;
    if (name.rfind("seq-", 0) == 0 && parseDigits(name, 4, number, digits_end) &&
        digits_end == name.size() && it->is_directory(type_ec))
      sequences[number] = it->path();
  }
  if (ec) return makeError(input.root.string() + ": cannot be listed: " + ec.message());
  if (sequences.empty())
    return makeError("no seq-XX folders in " + input.root.string() +
                     ": expected a 7-Scenes scene (seq-01/, seq-02/, ... with "
                     "TrainSplit.txt and TestSplit.txt)");

  std::set<int> chosen;
  if (input.split == "all") {
    for (const auto& [number, folder] : sequences) chosen.insert(number);
  } else {
    const fs::path split_file =
        input.root / (input.split == "train" ? "TrainSplit.txt" : "TestSplit.txt");
    auto lines = readLines(split_file);
    if (!lines) return makeError(lines.error() + " (needed for split '" + input.split + "')");
    for (size_t i = 0; i < lines->size(); ++i) {
      const std::string where = split_file.string() + ": line " + std::to_string(i + 1);
      std::string line = (*lines)[i];
      line.erase(0, line.find_first_not_of(" \t"));
      line.erase(line.find_last_not_of(" \t") + 1);
      if (line.empty()) continue;
      int number = 0;
      size_t digits_end = 0;
      if (line.rfind("sequence", 0) != 0 || !parseDigits(line, 8, number, digits_end) ||
          digits_end != line.size())
        return makeError(where + ": expected 'sequenceN', got '" + line + "'");
      if (!sequences.count(number))
        return makeError((input.root / sequenceFolderName(number)).string() +
                         ": missing (listed in " + where + ")");
      chosen.insert(number);
    }
    if (chosen.empty()) return makeError(split_file.string() + ": lists no sequences");
  }

  DatasetData data;
  data.depth_units_per_metre = 1000.0;
  if (auto status = readSevenScenesIntrinsics(input.root, data); !status)
    return makeError(status.error());
  // Keeps sequence * 1000 + 999 within int.
  constexpr int kMaxSequence = 2'000'000;
  for (int number : chosen) {
    if (number > kMaxSequence)
      return makeError(sequences[number].string() + ": sequence number is too large");
    if (auto status = readFrameFolder(sequences[number], input.selection, number * 1000, 999,
                                      NonFinitePose::Error, data);
        !status)
      return makeError(status.error());
  }
  return data;
}

}  // namespace relocalizer::detail
