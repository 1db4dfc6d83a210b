// Format handling, opening and frame loading shared by every dataset layout;
// the layout-specific list and pose readers are in dataset_*.cpp.

#include "relocalizer/data/dataset.h"

#include "relocalizer/core/id_ranges.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dataset_internal.h"

namespace relocalizer {

using detail::DatasetData;
using detail::DatasetFrame;
namespace fs = std::filesystem;

namespace {

std::string lowerCase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

std::string sizeText(const cv::Mat& image) { return sizeText(image.cols, image.rows); }

// "8-bit 3-channel", as people describe images rather than OpenCV type codes.
std::string describeType(const cv::Mat& image) {
  std::string depth;
  switch (image.depth()) {
    case CV_8U:
      depth = "8-bit";
      break;
    case CV_8S:
      depth = "8-bit signed";
      break;
    case CV_16U:
      depth = "16-bit";
      break;
    case CV_16S:
      depth = "16-bit signed";
      break;
    case CV_32S:
      depth = "32-bit integer";
      break;
    case CV_32F:
      depth = "32-bit float";
      break;
    case CV_64F:
      depth = "64-bit float";
      break;
    default:
      depth = "OpenCV depth " + std::to_string(image.depth());
      break;
  }
  return depth + " " + std::to_string(image.channels()) + "-channel";
}

Expected<cv::Mat> readImage(const std::string& path, int flags) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return makeError(path + ": missing");
  cv::Mat image;
  try {
    image = cv::imread(path, flags);
  } catch (const cv::Exception&) {
    // Some decoders throw on truncated files; same outcome as an empty result.
    image.release();
  }
  if (image.empty()) return makeError(path + ": cannot be read as an image");
  return image;
}

Expected<RgbdFrame> loadFrame(const DatasetData& data, const DatasetFrame& entry) {
  auto raw_depth = readImage(entry.depth_path, cv::IMREAD_UNCHANGED);
  if (!raw_depth) return makeError(raw_depth.error());
  if (raw_depth->type() != CV_16UC1)
    return makeError(entry.depth_path + ": expected 16-bit single-channel depth, got " +
                     describeType(*raw_depth));
  // EXIF orientation would silently rotate a JPEG away from its depth image.
  auto colour = readImage(entry.colour_path, cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION);
  if (!colour) return makeError(colour.error());

  if (colour->size() != raw_depth->size()) {
    if (!data.resample_colour)
      return makeError(entry.colour_path + " (" + sizeText(*colour) + ") and " + entry.depth_path +
                       " (" + sizeText(*raw_depth) +
                       ") differ in size; colour and depth must match");
    cv::Mat resampled;
    cv::resize(*colour, resampled, raw_depth->size(), 0, 0, cv::INTER_AREA);
    colour = std::move(resampled);
  }
  if (raw_depth->cols != data.camera.width || raw_depth->rows != data.camera.height)
    return makeError(entry.depth_path + ": expected " +
                     sizeText(data.camera.width, data.camera.height) +
                     " depth like the rest of the dataset, got " + sizeText(*raw_depth));

  auto depth = depthToMetres(*raw_depth, data.depth_units_per_metre);
  if (!depth) return makeError(entry.depth_path + ": " + depth.error());
  if (data.registration.enabled())
    colour = registerColourToDepth(*colour, *depth, data.camera, data.registration);

  RgbdFrame frame;
  frame.colour = std::move(*colour);
  frame.depth = std::move(*depth);
  frame.camera = data.camera;
  frame.stamp = entry.stamp;
  frame.id = entry.id;
  frame.ground_truth = entry.ground_truth;
  frame.source = entry.colour_path;
  return frame;
}

bool isFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool isFolder(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

// Whether any entry of `dir` satisfies `pred(name, is_folder)`.
template <typename Pred>
bool anyEntry(const fs::path& dir, Pred pred) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (pred(it->path().filename().string(), it->is_directory(type_ec))) return true;
  }
  return false;
}

bool hasSequenceFolders(const fs::path& dir) {
  return anyEntry(dir, [](const std::string& name, bool folder) {
    return folder && name.rfind("seq-", 0) == 0;
  });
}

bool hasFrameFiles(const fs::path& dir) {
  return anyEntry(dir, [](const std::string& name, bool folder) {
    if (folder || name.rfind("frame-", 0) != 0) return false;
    const auto ends_with = [&name](const std::string& suffix) {
      return name.size() >= suffix.size() &&
             name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
    };
    return ends_with(".pose.txt") || name.find(".color.") != std::string::npos;
  });
}

Expected<DatasetFormat> detectFormat(const fs::path& root) {
  if (isFile(root / "rgb.txt") && isFile(root / "depth.txt")) return DatasetFormat::Tum;
  if (isFile(root / "info.txt") && isFolder(root / "data")) return DatasetFormat::TwelveScenes;
  if (hasSequenceFolders(root)) return DatasetFormat::SevenScenesScene;
  if (hasFrameFiles(root)) return DatasetFormat::SevenScenesFolder;
  return makeError("cannot tell the dataset format of " + root.string() +
                   ": looked for rgb.txt + depth.txt (TUM RGB-D), info.txt + data/ "
                   "(12-Scenes / 4-Scenes), seq-XX/ folders (7-Scenes scene) and "
                   "frame-XXXXXX.color.png|jpg or frame-XXXXXX.pose.txt (7-Scenes folder)");
}

std::string formatNumber(double value, const char* format = "%g") {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

// Sum of camera-centre steps between frames with consecutive ids, so gaps in
// the selection and jumps between 7-Scenes sequences do not count as motion.
double groundTruthPathLength(const std::vector<DatasetFrame>& frames) {
  double length = 0.0;
  for (size_t i = 1; i < frames.size(); ++i) {
    const auto& a = frames[i - 1];
    const auto& b = frames[i];
    if (b.id == a.id + 1 && a.ground_truth && b.ground_truth)
      length += (b.ground_truth->translation() - a.ground_truth->translation()).norm();
  }
  return length;
}

Expected<DatasetData> readLayout(DatasetFormat format, const detail::ReaderInput& input) {
  switch (format) {
    case DatasetFormat::SevenScenesFolder:
      return detail::readSevenScenesFolder(input);
    case DatasetFormat::SevenScenesScene:
      return detail::readSevenScenesScene(input);
    case DatasetFormat::TwelveScenes:
      return detail::readTwelveScenes(input);
    case DatasetFormat::Tum:
      return detail::readTum(input);
    case DatasetFormat::Auto:
      break;
  }
  return makeError("internal error: no reader for format " + formatName(format));
}

Expected<std::unique_ptr<Dataset>> openDatasetUnchecked(const std::string& path,
                                                        const DatasetOptions& options) {
  if (path.empty()) return makeError("dataset path is empty");
  fs::path root = fs::path(path).lexically_normal();
  if (root.has_parent_path() && root.filename().empty()) root = root.parent_path();
  if (std::string problem = detail::folderProblem(root); !problem.empty())
    return makeError(problem);

  auto selection = FrameSelection::parse(options.frames);
  if (!selection) return makeError(selection.error());

  const std::string split = lowerCase(options.split.empty() ? "all" : options.split);
  if (split != "all" && split != "train" && split != "test")
    return makeError("unknown split '" + options.split + "': expected train, test or all");

  DatasetFormat format = options.format;
  if (format == DatasetFormat::Auto) {
    auto detected = detectFormat(root);
    if (!detected) return makeError(detected.error());
    format = *detected;
  } else if (format == DatasetFormat::SevenScenesFolder ||
             format == DatasetFormat::SevenScenesScene) {
    format = hasSequenceFolders(root) ? DatasetFormat::SevenScenesScene
                                      : DatasetFormat::SevenScenesFolder;
  }
  if (split != "all" && format != DatasetFormat::SevenScenesScene)
    return makeError("split '" + split + "' needs a 7-Scenes scene (seq-XX/ folders with " +
                     "TrainSplit.txt / TestSplit.txt), but " + root.string() + " is a " +
                     formatName(format) + "; use split 'all' and a frame selection instead");

  auto read = readLayout(format, detail::ReaderInput{root, *selection, split});
  if (!read) return makeError(read.error());
  auto data = std::make_unique<DatasetData>(std::move(*read));
  data->format = format;
  data->root = root.string();
  data->selection = selection->str();

  if (data->frames.empty())
    return makeError("frame selection '" + options.frames + "' matches none of the " +
                     std::to_string(data->all_ids.size()) + " frames of " + data->root +
                     " (frame ids " + formatIdRanges(data->all_ids) + ")");
  std::stable_sort(data->frames.begin(), data->frames.end(),
                   [](const DatasetFrame& a, const DatasetFrame& b) { return a.id < b.id; });

  if (!options.register_colour) {
    data->registration = ColourRegistration{};
    data->registration_source = "none (disabled by the caller)";
  }
  if (options.intrinsics) {
    data->camera.fx = options.intrinsics->fx;
    data->camera.fy = options.intrinsics->fy;
    data->camera.cx = options.intrinsics->cx;
    data->camera.cy = options.intrinsics->cy;
    data->camera_source = "given by the caller";
  }
  if (!data->camera_size_known) {
    // Intrinsics files carry no image size; the first depth image has it.
    auto first = readImage(data->frames.front().depth_path, cv::IMREAD_UNCHANGED);
    if (!first) return makeError(first.error());
    data->camera.width = first->cols;
    data->camera.height = first->rows;
  }
  if (std::string problem = data->camera.validationError(); !problem.empty())
    return makeError("camera intrinsics of " + data->root + " (" + data->camera_source +
                     "): " + problem);
  return std::make_unique<Dataset>(std::move(data));
}

}  // namespace

namespace detail {

std::string folderProblem(const fs::path& dir) {
  std::error_code ec;
  const auto status = fs::status(dir, ec);
  if (!fs::exists(status)) return dir.string() + ": no such folder";
  if (!fs::is_directory(status)) return dir.string() + ": not a folder";
  return {};
}

}  // namespace detail

Expected<DatasetFormat> parseDatasetFormat(const std::string& name) {
  const std::string key = lowerCase(name);
  if (key == "auto") return DatasetFormat::Auto;
  if (key == "7scenes") return DatasetFormat::SevenScenesFolder;
  if (key == "12scenes" || key == "4scenes") return DatasetFormat::TwelveScenes;
  if (key == "tum") return DatasetFormat::Tum;
  return makeError("unknown dataset format '" + name +
                   "': expected auto, 7scenes, 12scenes, 4scenes or tum");
}

std::string formatName(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::Auto:
      return "auto";
    case DatasetFormat::SevenScenesFolder:
      return "7-Scenes folder";
    case DatasetFormat::SevenScenesScene:
      return "7-Scenes scene";
    case DatasetFormat::TwelveScenes:
      return "12-Scenes";
    case DatasetFormat::Tum:
      return "TUM RGB-D";
  }
  return "unknown";
}

Dataset::Dataset(std::unique_ptr<const DatasetData> data) : data_(std::move(data)) {}
Dataset::~Dataset() = default;

size_t Dataset::size() const { return data_->frames.size(); }
int Dataset::id(size_t i) const { return data_->frames.at(i).id; }
double Dataset::stamp(size_t i) const { return data_->frames.at(i).stamp; }
const std::optional<Pose>& Dataset::groundTruth(size_t i) const {
  return data_->frames.at(i).ground_truth;
}
const CameraIntrinsics& Dataset::camera() const { return data_->camera; }
DatasetFormat Dataset::format() const { return data_->format; }
const std::string& Dataset::root() const { return data_->root; }

Expected<RgbdFrame> Dataset::load(size_t i) const {
  if (i >= size())
    return makeError("frame index " + std::to_string(i) + " is out of range: " + data_->root +
                     " has " + std::to_string(size()) + " selected frames");
  const DatasetFrame& entry = data_->frames[i];
  try {
    return loadFrame(*data_, entry);
  } catch (const std::exception& e) {
    // OpenCV allocation or conversion failures on hostile files.
    return makeError(entry.colour_path + ": " + e.what());
  }
}

std::string Dataset::summary() const {
  const DatasetData& d = *data_;
  std::vector<int> ids;
  ids.reserve(d.frames.size());
  int with_truth = 0;
  for (const auto& frame : d.frames) {
    ids.push_back(frame.id);
    with_truth += frame.ground_truth ? 1 : 0;
  }
  std::ostringstream out;
  out << "format:       " << formatName(d.format) << "\n";
  out << "root:         " << d.root << "\n";
  out << "frames:       " << d.frames.size() << " of " << d.all_ids.size();
  if (d.selection != "all") out << " selected by '" << d.selection << "'";
  out << ", ids " << formatIdRanges(ids) << "\n";
  out << "image size:   " << sizeText(d.camera.width, d.camera.height);
  if (d.colour_size &&
      (d.colour_size->width != d.camera.width || d.colour_size->height != d.camera.height))
    out << " (colour resampled from " << sizeText(d.colour_size->width, d.colour_size->height)
        << ")";
  out << "\n";
  out << "intrinsics:   fx " << formatNumber(d.camera.fx) << " fy " << formatNumber(d.camera.fy)
      << " cx " << formatNumber(d.camera.cx) << " cy " << formatNumber(d.camera.cy) << " ("
      << d.camera_source << ")\n";
  out << "colour:       registered by " << d.registration_source << "\n";
  out << "depth scale:  " << formatNumber(d.depth_units_per_metre) << " units per metre\n";
  out << "ground truth: " << with_truth << " of " << d.frames.size() << " frames\n";
  out << "path length:  " << formatNumber(groundTruthPathLength(d.frames), "%.2f")
      << " m (ground truth, between frames with consecutive ids)\n";
  return out.str();
}

Expected<std::unique_ptr<Dataset>> openDataset(const std::string& path,
                                               const DatasetOptions& options) {
  try {
    return openDatasetUnchecked(path, options);
  } catch (const std::exception& e) {
    // Filesystem races and allocation failures; the API promises no throws.
    return makeError(path + ": " + e.what());
  }
}

}  // namespace relocalizer
