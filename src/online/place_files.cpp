#include "relocalizer/online/place_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <mutex>

#include "relocalizer/core/file_io.h"
#include "relocalizer/core/outside_text.h"
#include "relocalizer/forest/model_io.h"
#include "relocalizer/online/submap_archive.h"
#include "relocalizer/online/submap_folder.h"

namespace relocalizer {
namespace {

// A turn among kConcurrentPlaceLoads, held for one load.
class LoadTurn {
 public:
  LoadTurn() {
    std::unique_lock<std::mutex> lock(mutex());
    turns().wait(lock, [] { return running() < kConcurrentPlaceLoads; });
    ++running();
  }
  ~LoadTurn() {
    {
      std::lock_guard<std::mutex> lock(mutex());
      --running();
    }
    turns().notify_one();
  }
  LoadTurn(const LoadTurn&) = delete;
  LoadTurn& operator=(const LoadTurn&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static std::condition_variable& turns() {
    static std::condition_variable c;
    return c;
  }
  static int& running() {
    static int n = 0;
    return n;
  }
};

// Whether `path` opens as a regular file that starts with `magic`
// (O_NONBLOCK: a FIFO never holds the check up).
bool opensWithMagic(const std::string& path, std::string_view magic, int flags = 0) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | flags);
  if (fd < 0) return false;
  struct stat info = {};
  std::string head(magic.size(), '\0');
  const bool ok = ::fstat(fd, &info) == 0 && S_ISREG(info.st_mode) &&
                  ::read(fd, head.data(), head.size()) == static_cast<ssize_t>(head.size()) &&
                  head == magic;
  ::close(fd);
  return ok;
}

// "place 'NAME': ", or nothing for a place opened under its saved name.
std::string placePrefix(const std::string& name) {
  return name.empty() ? std::string() : "place '" + name + "': ";
}

Expected<PlaceFiles> openUnbounded(const std::string& name, const std::string& path,
                                   const std::string& map_frame, const RelocalizerParams& params) {
  PlaceFiles files;
  std::error_code ec;
  if (!placeIsFolder(path)) {
    files.name = name.empty() ? pathStem(path) : name;
    files.map_frame = map_frame.empty() ? std::string("map") : map_frame;
    auto place = PlaceSet::load(files.name, path, files.map_frame, params);
    if (!place) return makeError(place.error());
    files.places.push_back(std::move(*place));
    return files;
  }
  if (!std::filesystem::exists(submapManifestPath(path), ec))
    return makeError(placePrefix(name) + path +
                     ": is a directory, not a model file nor a folder of learned submaps (it has "
                     "no " +
                     kSubmapManifestName + ")");
  auto saved = loadSavedSubmaps(path, name, map_frame, params);
  if (!saved) return makeError(placePrefix(name) + saved.error());
  files.folder = true;
  files.name = name.empty() ? saved->saved_place_name : name;
  files.map_frame = map_frame.empty() ? saved->saved_map_frame : map_frame;
  files.places = std::move(saved->places);
  files.saved_map_frame = std::move(saved->saved_map_frame);
  files.warnings = std::move(saved->warnings);
  return files;
}

}  // namespace

bool placeIsFolder(const std::string& path) {
  std::error_code ec;
  return !path.empty() && std::filesystem::is_directory(path, ec);
}

Expected<PlaceFiles> openPlace(const std::string& name, const std::string& path,
                               const std::string& map_frame, const RelocalizerParams& params) {
  const LoadTurn turn;
  try {
    return openUnbounded(name, path, map_frame, params);
  } catch (const std::exception& e) {
    return makeError(placePrefix(name) + path + ": cannot be loaded: " + loadFailureReason(e));
  }
}

Status putPlaceFiles(PlaceSet& set, const std::string& name, PlaceFiles files) {
  if (!files.folder && files.places.size() == 1) return set.put(std::move(files.places[0]));
  return set.putGroup(name, std::move(files.places));
}

std::string unreadablePlaceError(const std::string& name, const std::string& path) {
  if (!printableText(name) || !printableText(path))
    return "cannot load the place: its name or model path is not printable text (UTF-8 without "
           "control characters)";
  std::error_code ec;
  const bool loadable =
      std::filesystem::is_directory(path, ec)
          ? opensWithMagic(submapManifestPath(path), kSubmapManifestMagic.substr(0, 1), O_NOFOLLOW)
          : opensWithMagic(path, kModelMagic);
  if (loadable) return {};
  return "cannot load place '" + name + "': " + path +
         " is not a model file nor a folder of learned submaps that this node can read";
}

}  // namespace relocalizer
