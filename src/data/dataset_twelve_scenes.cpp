// 12-Scenes and 4-Scenes (Valentin et al.): the frame files of 7-Scenes under
// data/, plus an info.txt in the BundleFusion .sens header style giving the
// depth camera. Colour is 1296x968 against 640x480 depth, hence resampling.

#include <cmath>
#include <map>

#include "dataset_internal.h"

namespace relocalizer::detail {
namespace {

struct InfoValue {
  std::string text;
  int line = 0;
};

std::string trimmed(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return {};
  return s.substr(begin, s.find_last_not_of(" \t") - begin + 1);
}

class InfoFile {
 public:
  static Expected<InfoFile> read(const fs::path& file) {
    auto lines = readLines(file);
    if (!lines) return makeError(lines.error());
    InfoFile info;
    info.file_ = file;
    for (size_t i = 0; i < lines->size(); ++i) {
      const std::string line = trimmed((*lines)[i]);
      if (line.empty()) continue;
      const size_t equals = line.find('=');
      if (equals == std::string::npos)
        return makeError(file.string() + ": line " + std::to_string(i + 1) +
                         ": expected 'key = value', got '" + line + "'");
      info.values_[trimmed(line.substr(0, equals))] =
          InfoValue{trimmed(line.substr(equals + 1)), static_cast<int>(i) + 1};
    }
    return info;
  }

  bool has(const std::string& key) const { return values_.count(key) > 0; }

  // The numbers of `key`, which must have `count` of them.
  Expected<std::vector<double>> numbers(const std::string& key, size_t count,
                                        const std::string& example) const {
    const auto it = values_.find(key);
    if (it == values_.end())
      return makeError(file_.string() + ": missing " + key + " (expected a line like '" + key +
                       " = " + example + "')");
    const std::string where = file_.string() + ": line " + std::to_string(it->second.line);
    auto numbers = parseNumbers(it->second.text, file_, it->second.line);
    if (!numbers) return makeError(numbers.error());
    if (numbers->size() != count)
      return makeError(where + ": " + key + ": expected " + std::to_string(count) +
                       (count == 1 ? " number" : " numbers") + ", got " +
                       std::to_string(numbers->size()));
    for (double value : *numbers)
      if (!std::isfinite(value)) return makeError(where + ": " + key + ": expected finite numbers");
    return numbers;
  }

  Expected<int> positiveInteger(const std::string& key, const std::string& example) const {
    auto value = numbers(key, 1, example);
    if (!value) return makeError(value.error());
    const double v = value->front();
    if (!(v >= 1 && v <= 1e6 && v == std::floor(v)))
      return makeError(file_.string() + ": line " + std::to_string(values_.at(key).line) + ": " +
                       key + ": expected a positive integer, got '" + values_.at(key).text + "'");
    return static_cast<int>(v);
  }

 private:
  fs::path file_;
  std::map<std::string, InfoValue> values_;
};

}  // namespace

Expected<DatasetData> readTwelveScenes(const ReaderInput& input) {
  const fs::path info_path = input.root / "info.txt";
  auto info = InfoFile::read(info_path);
  if (!info) return makeError(info.error());

  DatasetData data;
  auto width = info->positiveInteger("m_depthWidth", "640");
  if (!width) return makeError(width.error());
  auto height = info->positiveInteger("m_depthHeight", "480");
  if (!height) return makeError(height.error());
  // Row-major 4x4 K, as in the .sens header.
  auto k =
      info->numbers("m_calibrationDepthIntrinsic", 16, "572 0 320 0 0 572 240 0 0 0 1 0 0 0 0 1");
  if (!k) return makeError(k.error());
  data.camera.fx = (*k)[0];
  data.camera.cx = (*k)[2];
  data.camera.fy = (*k)[5];
  data.camera.cy = (*k)[6];
  data.camera.width = *width;
  data.camera.height = *height;
  data.camera_size_known = true;
  data.camera_source = info_path.string() + " m_calibrationDepthIntrinsic";

  // Absent in some hand-written copies; 1000 is what every 12-Scenes scene uses.
  data.depth_units_per_metre = 1000.0;
  if (info->has("m_depthShift")) {
    auto shift = info->numbers("m_depthShift", 1, "1000");
    if (!shift) return makeError(shift.error());
    if (!(shift->front() > 0))
      return makeError(info_path.string() + ": m_depthShift must be positive");
    data.depth_units_per_metre = shift->front();
  }
  if (info->has("m_colorWidth") && info->has("m_colorHeight")) {
    auto colour_width = info->positiveInteger("m_colorWidth", "1296");
    if (!colour_width) return makeError(colour_width.error());
    auto colour_height = info->positiveInteger("m_colorHeight", "968");
    if (!colour_height) return makeError(colour_height.error());
    data.colour_size = cv::Size(*colour_width, *colour_height);
  }
  data.resample_colour = true;

  const fs::path frames_dir = input.root / "data";
  if (std::string problem = folderProblem(frames_dir); !problem.empty())
    return makeError(problem + " (12-Scenes frames are expected in data/)");
  if (auto status =
          readFrameFolder(frames_dir, input.selection, 0, -1, NonFinitePose::NoGroundTruth, data);
      !status)
    return makeError(status.error());
  return data;
}

}  // namespace relocalizer::detail
