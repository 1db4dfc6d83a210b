// A synthetic building: its rooms' recipes and placement, written as one
// dataset per room beside building.json.

#include "relocalizer/sim/synthetic_building.h"

#include <cctype>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

namespace relocalizer {
namespace {

namespace fs = std::filesystem;

const std::string kRoomPrefix = "room-";

std::string roomName(int index) { return kRoomPrefix + std::to_string(index); }

std::string roomCountError(int rooms) {
  if (rooms >= kMinBuildingRooms && rooms <= kMaxBuildingRooms) return {};
  return "rooms must be in [" + std::to_string(kMinBuildingRooms) + ", " +
         std::to_string(kMaxBuildingRooms) + "], got " + std::to_string(rooms);
}

// The index of a folder named like a room, or -1.
int roomIndex(const std::string& name) {
  if (name.rfind(kRoomPrefix, 0) != 0 || name.size() == kRoomPrefix.size() ||
      name.size() > kRoomPrefix.size() + 6)
    return -1;
  for (size_t i = kRoomPrefix.size(); i < name.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) return -1;
  return std::stoi(name.substr(kRoomPrefix.size()));
}

// The quarter turn about z that makes the door's wall face -y (its inward
// normal +y). Quarter turns have exact entries, so a room turned and placed
// keeps its coordinates to the bit where the turn is the identity.
Eigen::Matrix3d doorToMinusY(const RoomDoor& door) {
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d quarter;
  quarter << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  for (int q = 0; q < 4; ++q, turn = quarter * turn)
    if ((turn * door.inward - Eigen::Vector3d::UnitY()).norm() < 0.5) return turn;
  return Eigen::Matrix3d::Identity();  // unreachable: the door is on a wall
}

nlohmann::ordered_json vectorJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::ordered_json roomJson(const BuildingRoom& room, const std::vector<BuildingRoom>& rooms) {
  const Eigen::Matrix4d m = room.room_to_building.matrix();
  nlohmann::ordered_json matrix = nlohmann::ordered_json::array();
  for (int r = 0; r < 4; ++r) matrix.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  nlohmann::ordered_json json;
  json["name"] = room.name;
  json["folder"] = room.name;
  json["seed"] = room.recipe.layout_seed;
  json["appearance_seed"] = room.recipe.appearance_seed;
  json["looks_like"] = room.looks_like >= 0 ? nlohmann::ordered_json(rooms[room.looks_like].name)
                                            : nlohmann::ordered_json(nullptr);
  json["room_to_building"] = matrix;
  json["bounds_in_building"] = {{"min", vectorJson(room.bounds_in_building.min())},
                                {"max", vectorJson(room.bounds_in_building.max())}};
  json["door"] = {{"centre", vectorJson(room.door.centre)},
                  {"inward", vectorJson(room.door.inward)},
                  {"width", room.door.width},
                  {"height", room.door.height}};
  return json;
}

}  // namespace

Expected<std::vector<BuildingRoom>> buildingRooms(uint64_t seed, int rooms) {
  const std::string invalid = roomCountError(rooms);
  if (!invalid.empty()) return makeError("synthetic building: " + invalid);
  std::vector<BuildingRoom> result(rooms);
  double x = 0;
  for (int i = 0; i < rooms; ++i) {
    BuildingRoom& room = result[i];
    room.name = roomName(i);
    const uint64_t own_seed = seed + static_cast<uint64_t>(i);  // wraps, as intended
    room.recipe = {own_seed, own_seed};
    if (rooms >= 3 && i == rooms - 1) {
      room.recipe.appearance_seed = seed;
      room.looks_like = 0;
      result[0].looks_like = i;
    }
    const SyntheticRoom built(room.recipe);
    const Eigen::Matrix3d turn = doorToMinusY(built.door());
    const Eigen::AlignedBox3d own = built.bounds();
    Eigen::AlignedBox3d turned;
    for (int c = 0; c < 8; ++c)
      turned.extend(turn * own.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
    room.room_to_building = Eigen::Isometry3d::Identity();
    room.room_to_building.linear() = turn;
    room.room_to_building.translation() =
        Eigen::Vector3d(x - turned.min().x(), 0.0 - turned.min().y(), 0.0);
    room.bounds_in_building.setEmpty();
    for (int c = 0; c < 8; ++c)
      room.bounds_in_building.extend(room.room_to_building *
                                     own.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
    room.door = built.door();
    room.door.centre = room.room_to_building * room.door.centre;
    room.door.inward = turn * room.door.inward;
    x += turned.sizes().x() + kBuildingWallThickness;
  }
  return result;
}

Eigen::AlignedBox3d buildingCorridor(const std::vector<BuildingRoom>& rooms) {
  Eigen::AlignedBox3d all;
  for (const BuildingRoom& room : rooms) all.extend(room.bounds_in_building);
  return {Eigen::Vector3d(all.min().x(), kCorridorFarY, 0.0),
          Eigen::Vector3d(all.max().x(), kCorridorNearY, all.max().z())};
}

std::string SyntheticBuildingOptions::validationError() const {
  const std::string rooms_error = roomCountError(rooms);
  return rooms_error.empty() ? scene.validationError() : rooms_error;
}

Status writeSyntheticBuilding(const std::string& folder, const SyntheticBuildingOptions& options) {
  const std::string invalid = options.validationError();
  if (!invalid.empty()) return makeError("synthetic building options: " + invalid);
  if (folder.empty()) return makeError("no output folder given");
  const Expected<std::vector<BuildingRoom>> rooms =
      buildingRooms(options.scene.seed, options.rooms);
  if (!rooms) return makeError(rooms.error());
  const fs::path root(folder);
  std::error_code error;
  fs::create_directories(root, error);
  if (error) return makeError("cannot create " + root.string() + ": " + error.message());

  // A larger building written here before must not leave rooms behind that
  // building.json no longer names.
  std::vector<fs::path> stale;
  for (const auto& entry : fs::directory_iterator(root))
    if (entry.is_directory() && roomIndex(entry.path().filename().string()) >= options.rooms)
      stale.push_back(entry.path());
  if (fs::exists(root / kWalkFolder)) stale.push_back(root / kWalkFolder);
  for (const fs::path& path : stale) {
    fs::remove_all(path, error);
    if (error) return makeError("cannot remove stale " + path.string() + ": " + error.message());
  }

  nlohmann::ordered_json room_list = nlohmann::ordered_json::array();
  nlohmann::ordered_json pair = nlohmann::ordered_json::array();
  for (const BuildingRoom& room : *rooms) {
    SyntheticSceneOptions scene = options.scene;
    scene.seed = room.recipe.layout_seed;
    if (room.recipe.appearance_seed != room.recipe.layout_seed)
      scene.appearance_seed = room.recipe.appearance_seed;
    const Status written = writeSyntheticScene((root / room.name).string(), scene);
    if (!written) return makeError(room.name + ": " + written.error());
    room_list.push_back(roomJson(room, *rooms));
    if (room.looks_like >= 0) pair.push_back(room.name);
  }

  nlohmann::ordered_json json;
  json["generator"] = "relocalizer synthetic building";
  // 2 added each room's door and the corridor; format 1's fields are unchanged.
  json["format_version"] = 2;
  json["seed"] = options.scene.seed;
  json["look_alike_pair"] = pair;
  json["frame"] =
      "room_to_building maps each room's world frame (its scene.json and poses) into the "
      "building's: metres, z up, floors at z = 0, rooms in a row along x, each turned about z "
      "so that its door (centre of the leaf on the wall's plane) opens onto the corridor at y = 0";
  json["rooms"] = room_list;
  const Eigen::AlignedBox3d corridor = buildingCorridor(*rooms);
  json["corridor"] = {{"min", vectorJson(corridor.min())},
                      {"max", vectorJson(corridor.max())},
                      {"rendered", false}};
  const fs::path path = root / "building.json";
  std::ofstream out(path, std::ios::binary);
  out << json.dump(2) << "\n";
  if (!out) return makeError("cannot write " + path.string());
  return okStatus();
}

}  // namespace relocalizer
