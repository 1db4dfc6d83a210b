#include "relocalizer/core/file_io.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <filesystem>
#include <mutex>
#include <new>
#include <set>
#include <stdexcept>

namespace relocalizer {

namespace {

std::string temporaryPath(const std::string& path) {
  return path + ".tmp" + std::to_string(::getpid());
}

std::filesystem::path folderOf(const std::string& path) {
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  return folder.empty() ? std::filesystem::path(".") : folder;
}

// `<target>.tmp<pid>` of a process that is gone: a save killed between
// writing and renaming. A live process's temporary may be a save in progress
// (another node on the same path) and stays.
void removeStaleTemporaries(const std::string& path) {
  const std::string prefix = std::filesystem::path(path).filename().string() + ".tmp";
  std::error_code error;
  for (std::filesystem::directory_iterator it(folderOf(path), error), end; !error && it != end;
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    long pid = 0;
    const char* digits = name.data() + prefix.size();
    const auto [end_of_number, parse_error] =
        std::from_chars(digits, name.data() + name.size(), pid);
    if (parse_error != std::errc() || end_of_number != name.data() + name.size() || pid <= 0)
      continue;
    if (pid == ::getpid() || (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH))
      ::unlink(it->path().c_str());
  }
}

Status writeAndSync(const std::string& path, const std::string& temporary,
                    const std::vector<uint8_t>& bytes) {
  ::unlink(
      temporary.c_str());  // ours by name; O_EXCL below then never opens a planted FIFO or link
  const int fd =
      ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0666);
  if (fd < 0) {
    const std::string why = systemErrorText(errno);  // before any allocation can touch errno
    return makeError(path + ": cannot create the temporary file " + temporary + ": " + why);
  }
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(fd);
      return makeError(path + ": cannot write " + temporary + ": " + systemErrorText(error));
    }
    written += static_cast<size_t>(n);
  }
  // Without it a rename can reach the disk before the data: after a power
  // loss the target would exist but be empty or short.
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    return makeError(path + ": cannot flush " + temporary + " to disk: " + systemErrorText(error));
  }
  if (::close(fd) != 0) {
    const std::string why = systemErrorText(errno);
    return makeError(path + ": cannot write " + temporary + ": " + why);
  }
  return okStatus();
}

// Reads up to `size` bytes at `offset` of `bytes`; the refusal when it cannot.
std::string readInto(int fd, std::vector<uint8_t>& bytes, size_t offset, const std::string& what) {
  while (offset < bytes.size()) {
    const ssize_t n = ::read(fd, bytes.data() + offset, bytes.size() - offset);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const std::string why = systemErrorText(errno);
      return "cannot read " + what + ": " + why;
    }
    if (n == 0) return what + " shrank while it was read";
    offset += static_cast<size_t>(n);
  }
  return {};
}

// The refusal of what `fd` is, empty for a regular file that is not empty.
std::string fileTypeRefusal(int fd, const std::string& what, struct stat& info) {
  if (::fstat(fd, &info) != 0) {
    const std::string why = systemErrorText(errno);
    return "cannot inspect " + what + ": " + why;
  }
  if (S_ISDIR(info.st_mode)) return "is a directory, not a " + what;
  if (!S_ISREG(info.st_mode)) return "is not a regular file (a device or a pipe?), not a " + what;
  if (info.st_size == 0) return what + " is empty";
  return {};
}

}  // namespace

std::string systemErrorText(int error) {
  switch (error) {
    case EACCES:
    case EPERM:
      return "permission denied";
    case ENOENT:
      return "no such file or folder";
    case ENOTDIR:
      return "a part of the path is not a folder";
    case EISDIR:
      return "it is a folder";
    case ENAMETOOLONG:
      return "the name is too long";
    case ELOOP:
      return "too many symbolic links in the path";
    case EEXIST:
      return "something is already there";
    case ENOSPC:
      return "no space left on the disk";
    case EDQUOT:
      return "the disk quota is used up";
    case EFBIG:
      return "the file would exceed the size limit of the file system or the process";
    case EROFS:
      return "the file system is read-only";
    case EIO:
      return "input/output error of the disk";
    case EXDEV:
      return "the temporary and the target are on different file systems";
    case EBUSY:
      return "the file or folder is in use";
    case EMFILE:
    case ENFILE:
      return "too many open files";
    case ENOMEM:
      return "out of memory";
    case EINVAL:
      return "the file system does not support it";
    default:
      return "system error " + std::to_string(error);
  }
}

Expected<std::vector<uint8_t>> readRegularFile(const std::string& path, const FileFormat& format) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer
  // for good; the type is then checked on what was opened.
  const int fd = ::open(path.c_str(),
                        O_RDONLY | O_NONBLOCK | O_CLOEXEC | (format.follow_link ? 0 : O_NOFOLLOW));
  if (fd < 0) {
    const int error = errno;
    if (error == ELOOP && !format.follow_link)
      return makeError(path + ": is a symbolic link, not followed: a " + format.what +
                       " must be the file itself");
    return makeError(path + ": cannot open " + format.what + ": " + systemErrorText(error));
  }
  struct stat info = {};
  std::string refusal = fileTypeRefusal(fd, format.what, info);
  std::vector<uint8_t> bytes;
  if (refusal.empty()) {
    const uint64_t size = static_cast<uint64_t>(info.st_size);
    bytes.resize(static_cast<size_t>(std::min<uint64_t>(format.head_bytes, size)));
    refusal = readInto(fd, bytes, 0, format.what);
    uint64_t length = 0;
    if (refusal.empty()) {
      const Expected<uint64_t> named = format.length(bytes, size);
      if (!named)
        refusal = named.error();
      else if (*named > size)
        refusal = format.what + " is truncated: it holds " + std::to_string(size) +
                  " bytes, its header names " + std::to_string(*named);
      else
        length = *named;
    }
    if (refusal.empty()) {
      // One read into a sized buffer: a byte-wise stream copy of a 70 MB
      // model costs a second of start-up.
      const size_t head = bytes.size();
      bytes.resize(static_cast<size_t>(length));
      if (head < bytes.size()) refusal = readInto(fd, bytes, head, format.what);
    }
  }
  ::close(fd);
  if (!refusal.empty()) return makeError(path + ": " + refusal);
  return bytes;
}

FileFormat sizeLimitedFile(const std::string& what, uint64_t max_bytes) {
  FileFormat format;
  format.what = what;
  format.length = [what, max_bytes](const std::vector<uint8_t>&,
                                    uint64_t size) -> Expected<uint64_t> {
    if (size > max_bytes)
      return makeError(what + " is " + std::to_string(size) + " bytes, more than the " +
                       std::to_string(max_bytes) + " one may hold");
    return size;
  };
  return format;
}

std::string loadFailureReason(const std::exception& error) {
  if (dynamic_cast<const std::bad_alloc*>(&error))
    return "too large to load (out of memory: a size in it may be damaged)";
  if (dynamic_cast<const std::length_error*>(&error) ||
      dynamic_cast<const std::out_of_range*>(&error))
    return "a size or number in it is out of range";
  return "cannot be read";
}

std::string replaceableError(const std::string& path, std::string_view magic,
                             const std::string& what) {
  struct stat info = {};
  if (::lstat(path.c_str(), &info) != 0) {
    if (errno == ENOENT) return {};  // a new file; a missing folder is reported by the write
    const std::string why = systemErrorText(errno);
    return path + ": cannot check what is there: " + why;
  }
  if (S_ISLNK(info.st_mode))
    return path +
           ": is a symbolic link; refusing to replace it (name the file itself or a new path)";
  if (S_ISDIR(info.st_mode)) return path + ": is a directory; refusing to replace it (name a file)";
  if (!S_ISREG(info.st_mode))
    return path + ": is not a regular file (a FIFO, socket or device); refusing to replace it";
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    const std::string why = systemErrorText(errno);
    return path + ": cannot read the existing file to check it: " + why;
  }
  std::string head(magic.size(), '\0');
  const ssize_t n = ::read(fd, head.data(), head.size());
  ::close(fd);
  if (n != static_cast<ssize_t>(magic.size()) || head != magic)
    return path + ": exists and is not a " + what +
           "; refusing to overwrite it (remove it or choose another path)";
  return {};
}

Status replaceFiles(const std::vector<FileReplacement>& files) {
  // Two saves in one process (two service calls) would share temporaries' names.
  static std::mutex one_at_a_time;
  std::lock_guard<std::mutex> lock(one_at_a_time);
  for (const FileReplacement& f : files)
    if (const std::string why = replaceableError(f.path, f.magic, f.what); !why.empty())
      return makeError(why);
  std::vector<std::string> temporaries;
  const auto fail = [&](const std::string& why) {
    for (const std::string& t : temporaries) ::unlink(t.c_str());
    return makeError(why);
  };
  for (const FileReplacement& f : files) {
    removeStaleTemporaries(f.path);
    temporaries.push_back(temporaryPath(f.path));
    if (Status written = writeAndSync(f.path, temporaries.back(), f.bytes); !written)
      return fail(written.error());
  }
  for (size_t i = 0; i < files.size(); ++i) {
    if (::rename(temporaries[i].c_str(), files[i].path.c_str()) != 0) {
      const int error = errno;
      temporaries.erase(temporaries.begin(), temporaries.begin() + static_cast<std::ptrdiff_t>(i));
      return fail(files[i].path + ": cannot rename " + temporaries.front() +
                  " into place: " + systemErrorText(error));
    }
  }
  // The renames are entries of the folder: durable only once it is flushed.
  std::set<std::string> folders;
  for (const FileReplacement& f : files) folders.insert(folderOf(f.path).string());
  for (const std::string& folder : folders) {
    const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0 || (::fsync(fd) != 0 && errno != EINVAL)) {
      const int error = errno;
      if (fd >= 0) ::close(fd);
      return makeError(files.front().path + ": written, but the folder " + folder +
                       " could not be flushed to disk: " + systemErrorText(error));
    }
    ::close(fd);
  }
  return okStatus();
}

std::string pathStem(const std::string& path) {
  std::filesystem::path p(path);
  if (!p.has_filename()) p = p.parent_path();
  return p.stem().string();
}

}  // namespace relocalizer
