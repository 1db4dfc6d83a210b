// TUM RGB-D (Sturm et al., IROS 2012): colour and depth are separate streams
// with their own timestamps and the motion-capture ground truth runs at a
// third rate, so frames are paired and ground truth interpolated here.

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "dataset_internal.h"
#include "relocalizer/data/stamp_association.h"
#include "relocalizer/data/tum_trajectory.h"

namespace relocalizer::detail {
namespace {

// associate.py's default: half a frame period at 30 Hz.
constexpr double kMaxAssociationGap = 0.02;
// Interpolating across a longer motion-capture dropout would invent a pose.
constexpr double kMaxInterpolationGap = 0.1;
// Without a bracketing pair, the nearest sample must be this close.
constexpr double kMaxNearestGap = 0.02;
constexpr double kTumDepthUnitsPerMetre = 5000.0;

struct ListEntry {
  double stamp = 0.0;
  std::string file;
  int line = 0;
};

// rgb.txt / depth.txt: "timestamp filename" lines, '#' comments; sorted by stamp.
Expected<std::vector<ListEntry>> readImageList(const fs::path& file) {
  auto lines = readLines(file);
  if (!lines) return makeError(lines.error());
  std::vector<ListEntry> entries;
  for (size_t i = 0; i < lines->size(); ++i) {
    const std::string& line = (*lines)[i];
    if (isCommentOrBlank(line)) continue;
    const int line_number = static_cast<int>(i) + 1;
    std::istringstream tokens(line);
    std::string stamp_text, name, extra;
    tokens >> stamp_text >> name;
    if (name.empty() || (tokens >> extra))
      return makeError(file.string() + ": line " + std::to_string(line_number) +
                       ": expected 'timestamp filename', got '" + line + "'");
    auto stamp = parseNumbers(stamp_text, file, line_number);
    if (!stamp) return makeError(stamp.error());
    if (!std::isfinite(stamp->front()))
      return makeError(file.string() + ": line " + std::to_string(line_number) +
                       ": timestamp must be finite");
    entries.push_back({stamp->front(), name, line_number});
  }
  if (entries.empty()) return makeError(file.string() + ": lists no images");
  std::stable_sort(entries.begin(), entries.end(),
                   [](const ListEntry& a, const ListEntry& b) { return a.stamp < b.stamp; });
  return entries;
}

// Pairs (rgb index, depth index) as TUM's associate.py, whose test is strict
// (a gap below kMaxAssociationGap, not equal to it).
std::vector<std::pair<size_t, size_t>> associate(const std::vector<ListEntry>& rgb,
                                                 const std::vector<ListEntry>& depth) {
  const auto stamps = [](const std::vector<ListEntry>& list) {
    std::vector<double> out;
    out.reserve(list.size());
    for (const ListEntry& e : list) out.push_back(e.stamp);
    return out;
  };
  return associateByStamp(stamps(rgb), stamps(depth), std::nextafter(kMaxAssociationGap, 0.0));
}

std::optional<Pose> groundTruthAt(const std::vector<TrajectorySample>& samples, double stamp) {
  if (samples.empty()) return std::nullopt;
  const auto after =
      std::lower_bound(samples.begin(), samples.end(), stamp,
                       [](const TrajectorySample& s, double t) { return s.stamp < t; });
  if (after != samples.end() && after->stamp == stamp)
    return poseFromTranslationQuaternion(after->translation, after->rotation);
  if (after != samples.begin() && after != samples.end()) {
    const auto before = after - 1;
    const double gap = after->stamp - before->stamp;
    if (gap <= kMaxInterpolationGap) {
      const double a = (stamp - before->stamp) / gap;
      return poseFromTranslationQuaternion((1.0 - a) * before->translation + a * after->translation,
                                           before->rotation.slerp(a, after->rotation));
    }
  }
  const TrajectorySample* nearest = nullptr;
  if (after != samples.end()) nearest = &*after;
  if (after != samples.begin()) {
    const auto before = after - 1;
    if (!nearest || stamp - before->stamp < nearest->stamp - stamp) nearest = &*before;
  }
  if (std::abs(nearest->stamp - stamp) <= kMaxNearestGap)
    return poseFromTranslationQuaternion(nearest->translation, nearest->rotation);
  return std::nullopt;
}

// The TUM sequences name their camera in the folder name
// (rgbd_dataset_freiburg1_xyz); values from the TUM "file formats" page.
void setDefaultIntrinsics(const fs::path& root, DatasetData& data) {
  std::error_code ec;
  fs::path resolved = fs::weakly_canonical(root, ec);
  if (ec || resolved.filename().empty()) resolved = root;
  std::string name = resolved.filename().string();
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto named = [&name](const char* long_name, const char* short_name) {
    return name.find(long_name) != std::string::npos || name.find(short_name) != std::string::npos;
  };
  const std::string from = " (from the folder name '" + resolved.filename().string() + "')";
  const auto set = [&data](double fx, double fy, double cx, double cy) {
    data.camera.fx = fx;
    data.camera.fy = fy;
    data.camera.cx = cx;
    data.camera.cy = cy;
  };
  if (named("freiburg1", "fr1")) {
    set(517.3, 516.5, 318.6, 255.3);
    data.camera_source = "TUM freiburg1 calibration" + from;
  } else if (named("freiburg2", "fr2")) {
    set(520.9, 521.0, 325.1, 249.7);
    data.camera_source = "TUM freiburg2 calibration" + from;
  } else if (named("freiburg3", "fr3")) {
    set(535.4, 539.2, 320.1, 247.6);
    data.camera_source = "TUM freiburg3 calibration" + from;
  } else {
    set(525.0, 525.0, 319.5, 239.5);
    data.camera_source = "TUM default calibration; folder name '" + resolved.filename().string() +
                         "' names no freiburg1/2/3 camera";
  }
}

}  // namespace

Expected<DatasetData> readTum(const ReaderInput& input) {
  const fs::path rgb_file = input.root / "rgb.txt";
  const fs::path depth_file = input.root / "depth.txt";
  auto rgb = readImageList(rgb_file);
  if (!rgb) return makeError(rgb.error());
  auto depth = readImageList(depth_file);
  if (!depth) return makeError(depth.error());

  // Some TUM sequences (the validation set) ship without ground truth.
  std::vector<TrajectorySample> truth;
  const fs::path truth_file = input.root / "groundtruth.txt";
  std::error_code ec;
  if (fs::exists(truth_file, ec)) {
    auto read = readTumTrajectory(truth_file.string());
    if (!read) return makeError(read.error());
    truth = std::move(*read);
  }

  const auto matches = associate(*rgb, *depth);
  if (matches.empty())
    return makeError("no depth image within 0.02 s of any colour image: " + rgb_file.string() +
                     " and " + depth_file.string() + " do not overlap in time");

  DatasetData data;
  data.depth_units_per_metre = kTumDepthUnitsPerMetre;
  setDefaultIntrinsics(input.root, data);
  for (size_t k = 0; k < matches.size(); ++k) {
    const int id = static_cast<int>(k);
    data.all_ids.push_back(id);
    if (!input.selection.contains(id)) continue;
    const ListEntry& colour = (*rgb)[matches[k].first];
    const ListEntry& depth_entry = (*depth)[matches[k].second];
    DatasetFrame frame;
    frame.id = id;
    frame.stamp = colour.stamp;
    frame.colour_path = (input.root / colour.file).string();
    frame.depth_path = (input.root / depth_entry.file).string();
    // Checked now so a broken copy fails at open, not hours into a run.
    std::error_code exists_ec;
    if (!fs::exists(frame.colour_path, exists_ec))
      return makeError(frame.colour_path + ": missing (listed in " + rgb_file.string() + " line " +
                       std::to_string(colour.line) + ")");
    if (!fs::exists(frame.depth_path, exists_ec))
      return makeError(frame.depth_path + ": missing (listed in " + depth_file.string() + " line " +
                       std::to_string(depth_entry.line) + ")");
    frame.ground_truth = groundTruthAt(truth, colour.stamp);
    data.frames.push_back(std::move(frame));
  }
  return data;
}

}  // namespace relocalizer::detail
