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
#include <exception>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "relocalizer/core/expected.h"

namespace relocalizer {

// What a reader knows of its kind of file before reading one: how many bytes
// to look at first, and from them how many the file holds (its header's
// length field, or its size when that is within a limit), or why it is not
// such a file. A 2 GB file that is not ours then costs a read of its head.
struct FileFormat {
  std::string what;         // the kind of file, for messages ("model file")
  size_t head_bytes = 0;    // read first, fewer when the file is shorter
  bool follow_link = true;  // false: a symbolic link at the path is refused
  // From the head and the file's size: the bytes to read, at most the size
  // (else the file is reported truncated), or an error (without the path:
  // the reader names it).
  std::function<Expected<uint64_t>(const std::vector<uint8_t>& head, uint64_t file_size)> length;
};

// The first `length` bytes of a regular file as `format` says. Directories,
// FIFOs and devices are refused without blocking; messages name the path.
Expected<std::vector<uint8_t>> readRegularFile(const std::string& path, const FileFormat& format);

// The whole of a small regular file: more than `max_bytes` is refused unread.
FileFormat sizeLimitedFile(const std::string& what, uint64_t max_bytes);

// What a loader says of an exception it caught, in our words (a library's
// text may quote the file's bytes): out of memory, a size out of range, or
// that the file cannot be read.
std::string loadFailureReason(const std::exception& error);

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
// target may be replaced, and no temporary is left. A failure before the first
// rename leaves every target as it was; a rename that fails leaves the targets
// renamed before it replaced (callers order the files so that this is safe: key
// frames, then the model, then the manifest); a failure to flush the folder comes
// after every target was replaced (written, but maybe not yet durable). Messages
// name the path, what failed and why (systemErrorText).
Status replaceFiles(const std::vector<FileReplacement>& files);

// Why a system call failed (an errno value), in our words: the C library's
// text follows the locale and may be translated or not UTF-8, and it goes
// into ROS answers and logs.
std::string systemErrorText(int error);

// The stem of the path's last component, trailing separators ignored: what a
// place is called by default, for a model file ("kitchen.model") and a folder
// of submaps ("learned/") alike.
std::string pathStem(const std::string& path);

}  // namespace relocalizer
