#pragma once
// Reading and replacing the package's own files (models, key frames) so that
// a path from a user or a peer on the ROS graph can neither hang the reader
// nor make the writer destroy something that is not ours, and a save killed
// half way leaves the old files whole.
//
// Replacing files: every target is checked first (lstat: a symlink, FIFO,
// device or directory is refused, and so is a regular file that does not start
// with the expected magic), then each is written to `<target>.tmp<pid>` beside
// it, fsynced, renamed over its target in the order given, and the folder is
// fsynced, so after a crash or power loss each target is wholly old or new.
// Temporaries that a killed save left (`<target>.tmp<pid>` of a process that
// no longer runs) are removed by the next save of the same target.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "relocalizer/core/expected.h"

namespace relocalizer {

// The whole content of a regular file. Directories, FIFOs and devices are
// refused without blocking; `what` names the kind of file in messages.
Expected<std::vector<uint8_t>> readRegularFile(const std::string& path, const std::string& what);

struct FileReplacement {
  std::string path;
  std::string_view magic;  // an existing target must start with these bytes
  std::string what;        // the kind of file, for messages ("relocalizer model file")
  std::vector<uint8_t> bytes;
};

// Empty when `path` may be replaced by a file of `magic`, else why not
// (naming the path).
std::string replaceableError(const std::string& path, std::string_view magic,
                             const std::string& what);

// Replaces every target as described above; nothing is written unless every
// target may be replaced. Messages name the path and carry the system's reason.
Status replaceFiles(const std::vector<FileReplacement>& files);

// The stem of the path's last component, trailing separators ignored: what a
// place is called by default, for a model file ("kitchen.model") and a folder
// of submaps ("learned/") alike.
std::string pathStem(const std::string& path);

}  // namespace relocalizer
