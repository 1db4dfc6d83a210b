#include "relocalizer/online/submap_folder.h"

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "relocalizer/core/file_io.h"
#include "relocalizer/core/json_fields.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/online/online_learner.h"

namespace relocalizer {
namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kFormatName = "relocalizer learned submaps";

Json poseJson(const Pose& pose) {
  Json rows = Json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) rows.push_back(pose.matrix()(r, c));
  return rows;
}

// A field of the manifest by its path (`submaps[2].model`), so a reader's
// error says which one is wrong.
class Field {
 public:
  Field(const Json& json, std::string path) : json_(json), path_(std::move(path)) {}

  Field at(const char* key) const {
    const std::string path = path_.empty() ? key : path_ + "." + key;
    if (!json_.is_object() || !json_.contains(key)) throw std::runtime_error(path + " is missing");
    return Field(json_.at(key), path);
  }
  Field at(size_t i) const { return Field(json_.at(i), path_ + "[" + std::to_string(i) + "]"); }
  size_t size(size_t expected = 0) const {
    if (!json_.is_array()) throw std::runtime_error(path_ + " must be an array");
    if (expected && json_.size() != expected)
      throw std::runtime_error(path_ + " must hold " + std::to_string(expected) + " numbers");
    return json_.size();
  }
  std::string text() const {
    if (!json_.is_string()) throw std::runtime_error(path_ + " must be a string");
    return json_.get<std::string>();
  }
  template <typename T>
  T number() const {
    // checkedNumber's messages quote the field's path.
    return detail::checkedNumber<T>(nlohmann::json(json_), path_);
  }
  // A file name inside the folder: a manifest must not reach other files.
  std::string fileName() const {
    const std::string name = text();
    if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos)
      throw std::runtime_error(path_ + " must name a file in the folder (got " +
                               detail::quoted(nlohmann::json(json_)) + ")");
    return name;
  }
  const std::string& path() const { return path_; }

 private:
  const Json& json_;
  std::string path_;
};

Pose readPose(const Field& field) {
  field.size(12);
  Pose pose = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      pose.matrix()(r, c) = field.at(static_cast<size_t>(4 * r + c)).number<double>();
  if (const std::string why = slamPoseError(pose); !why.empty())
    throw std::runtime_error(field.path() + ": " + why);
  return pose;
}

int boundedIndex(const Field& field) {
  const int index = field.number<int>();
  if (index < 0 || index > kMaxSubmapIndex)
    throw std::runtime_error(field.path() + " must be from 0 to " +
                             std::to_string(kMaxSubmapIndex));
  return index;
}

SubmapEntry readEntry(const Field& f) {
  SubmapEntry e;
  e.index = boundedIndex(f.at("index"));
  e.name = f.at("name").text();
  const std::string state = f.at("state").text();
  if (state != "frozen" && state != "active")
    throw std::runtime_error(f.at("state").path() + " must be \"frozen\" or \"active\" (got " +
                             detail::quoted(nlohmann::json(state)) + ")");
  e.frozen = state == "frozen";
  if (e.frozen || !f.at("model").text().empty()) {
    e.model = f.at("model").fileName();
    e.model_id.crc = f.at("model_id").at("crc").number<uint32_t>();
    e.model_id.size = f.at("model_id").at("size").number<uint64_t>();
  }
  e.keyframes = f.at("keyframes").fileName();
  const Field poses = f.at("keyframe_poses");
  const size_t count = poses.size();
  if (f.at("keyframe_count").number<size_t>() != count)
    throw std::runtime_error(f.at("keyframe_count").path() + " differs from the " +
                             std::to_string(count) + " entries of " + poses.path());
  for (size_t k = 0; k < count; ++k) {
    const Field pose = poses.at(k);
    const std::int64_t id = pose.at("id").number<std::int64_t>();
    if (id < 0 || id > kMaxKeyFrameId)
      throw std::runtime_error(pose.at("id").path() + " must be from 0 to " +
                               std::to_string(kMaxKeyFrameId));
    e.keyframe_poses.push_back({id, readPose(pose.at("pose"))});
  }
  return e;
}

SubmapManifest readManifest(const Json& json) {
  const Field root(json, "");
  if (root.at("format").text() != kFormatName)
    throw std::runtime_error("format is not \"" + std::string(kFormatName) + "\"");
  const int version = root.at("format_version").number<int>();
  if (version != kSubmapFormatVersion)
    throw std::runtime_error("format_version " + std::to_string(version) +
                             " is not one this build reads (" +
                             std::to_string(kSubmapFormatVersion) + ")");
  SubmapManifest m;
  m.place_name = root.at("place_name").text();
  m.map_frame = root.at("map_frame").text();
  m.software_version = root.at("software_version").text();
  const Field learning = root.at("learning");
  m.min_motion.metres = learning.at("min_motion").at("metres").number<double>();
  m.min_motion.degrees = learning.at("min_motion").at("degrees").number<double>();
  m.max_keyframes = learning.at("max_keyframes").number<int>();
  m.submap_params.area_radius = learning.at("area_radius").number<double>();
  m.submap_params.overlap = learning.at("overlap").number<int>();
  m.submap_params.cover_steps = learning.at("cover_steps").number<double>();
  m.submap_params.min_submap_keyframes = learning.at("min_submap_keyframes").number<int>();
  m.active = root.at("active").number<int>() == -1 ? -1 : boundedIndex(root.at("active"));
  const Field submaps = root.at("submaps");
  std::set<int> indices;
  for (size_t i = 0; i < submaps.size(); ++i) {
    SubmapEntry e = readEntry(submaps.at(i));
    if (!m.submaps.empty() && e.index <= m.submaps.back().index)
      throw std::runtime_error(submaps.at(i).at("index").path() +
                               " must be greater than the one before (" +
                               std::to_string(m.submaps.back().index) + ")");
    if (!e.frozen && e.index != m.active)
      throw std::runtime_error(submaps.at(i).at("state").path() + " is \"active\" but active is " +
                               std::to_string(m.active));
    m.submaps.push_back(std::move(e));
  }
  if (m.active >= 0) {
    bool named = false;
    for (const SubmapEntry& e : m.submaps) named = named || (e.index == m.active && !e.frozen);
    if (!named)
      throw std::runtime_error("active " + std::to_string(m.active) +
                               " names no submap of state \"active\"");
  }
  return m;
}

}  // namespace

std::string submapFileName(int index) {
  char name[32];
  std::snprintf(name, sizeof name, "submap-%04d.model", index);
  return name;
}

std::string submapPlaceName(const std::string& place, int index) {
  return place + "/" + std::to_string(index);
}

std::string submapManifestPath(const std::string& folder) {
  return (std::filesystem::path(folder) / kSubmapManifestName).string();
}

Expected<std::string> confinedSaveFolder(const std::string& root, const std::string& requested) {
  namespace fs = std::filesystem;
  const std::string quoted = printableText(requested) ? requested : "the requested path";
  if (requested.empty()) return makeError("path is empty: name the folder to write");
  std::error_code ec;
  fs::create_directories(root, ec);
  const fs::path base = fs::canonical(root, ec);
  if (ec)
    return makeError(root + ": cannot use it as the save folder: " + systemErrorText(ec.value()));
  const auto inside = [&](const fs::path& p) {
    const fs::path relative = p.lexically_relative(base);
    return !relative.empty() && *relative.begin() != ".." && relative != ".";
  };
  const fs::path asked = (base / requested).lexically_normal();  // `requested` when absolute
  const std::string outside = quoted + ": not inside the save folder " + base.string() +
                              " (symbolic links resolved): saves go only into a new, empty or "
                              "saved folder inside it (parameter save_model_folder)";
  // The lexical check first: a path outside is refused without looking at it.
  if (!inside(asked)) return makeError(outside);
  const fs::path resolved = fs::weakly_canonical(asked, ec);
  if (ec || !inside(resolved)) return makeError(outside);
  if (!fs::exists(resolved, ec)) return resolved.string();
  if (!fs::is_directory(resolved, ec))
    return makeError(resolved.string() + ": is not a folder; a learned set is saved as one folder");
  // A saved set: our manifest, or (a set whose first freeze is not yet
  // named) submap files alone.
  const std::string manifest = submapManifestPath(resolved.string());
  const bool named = fs::exists(fs::symlink_status(manifest, ec));
  bool ours = !named || replaceableError(manifest, kSubmapManifestMagic, "manifest").empty();
  if (!named)
    for (fs::directory_iterator it(resolved, ec), end; ours && !ec && it != end; it.increment(ec))
      ours = it->path().filename().string().rfind("submap-", 0) == 0;
  if (ec || !ours)
    return makeError(resolved.string() +
                     ": holds files that are not a saved set of learned submaps; refusing to "
                     "write into it (name a new or empty folder, or an earlier save)");
  return resolved.string();
}

FileReplacement submapManifestReplacement(const std::string& folder,
                                          const SubmapManifest& manifest) {
  const std::string text = serializeSubmapManifest(manifest);
  return FileReplacement{submapManifestPath(folder), kSubmapManifestMagic,
                         "learned-submaps manifest",
                         std::vector<uint8_t>(text.begin(), text.end())};
}

std::string serializeSubmapManifest(const SubmapManifest& m) {
  Json json;
  json["format"] = kFormatName;
  json["format_version"] = kSubmapFormatVersion;
  json["place_name"] = m.place_name;
  json["map_frame"] = m.map_frame;
  json["software_version"] = m.software_version;
  Json learning;
  learning["min_motion"] = {{"metres", m.min_motion.metres}, {"degrees", m.min_motion.degrees}};
  learning["max_keyframes"] = m.max_keyframes;
  learning["area_radius"] = m.submap_params.area_radius;
  learning["overlap"] = m.submap_params.overlap;
  learning["cover_steps"] = m.submap_params.cover_steps;
  learning["min_submap_keyframes"] = m.submap_params.min_submap_keyframes;
  json["learning"] = learning;
  json["active"] = m.active;
  Json submaps = Json::array();
  for (const SubmapEntry& e : m.submaps) {
    Json s;
    s["index"] = e.index;
    s["name"] = e.name;
    s["state"] = e.frozen ? "frozen" : "active";
    s["model"] = e.model;
    s["keyframes"] = e.keyframes;
    s["keyframe_count"] = e.keyframe_poses.size();
    if (!e.model.empty()) s["model_id"] = {{"crc", e.model_id.crc}, {"size", e.model_id.size}};
    Json poses = Json::array();
    for (const SubmapKeyFrame& k : e.keyframe_poses)
      poses.push_back({{"id", k.id}, {"pose", poseJson(k.pose)}});
    s["keyframe_poses"] = std::move(poses);
    submaps.push_back(std::move(s));
  }
  json["submaps"] = std::move(submaps);
  return json.dump(2) + "\n";
}

Expected<SubmapManifest> readSubmapManifest(const std::string& folder) {
  const std::string path = submapManifestPath(folder);
  FileFormat format = sizeLimitedFile("submap manifest", kMaxSubmapManifestBytes);
  format.follow_link = false;
  auto bytes = readRegularFile(path, format);
  if (!bytes) return makeError(bytes.error());
  return parseSubmapManifest(std::string(bytes->begin(), bytes->end()), path);
}

Expected<SubmapManifest> parseSubmapManifest(const std::string& text, const std::string& path) {
  try {
    return readManifest(Json::parse(text));
  } catch (const std::exception& e) {
    return makeError(path + ": not a learned-submaps manifest: " + detail::jsonErrorReason(e));
  }
}

}  // namespace relocalizer
