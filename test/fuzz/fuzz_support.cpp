#include "fuzz_support.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace relocalizer::fuzz {

namespace fs = std::filesystem;

std::vector<std::string> splitParts(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string separator = kPartSeparator;
  std::vector<std::string> parts(1);
  size_t begin = 0;
  while (begin <= text.size()) {
    size_t end = text.find('\n', begin);
    const bool last = end == std::string::npos;
    if (last) end = text.size();
    const std::string line = text.substr(begin, end - begin);
    if (line == separator) {
      parts.emplace_back();
    } else {
      parts.back() += line;
      if (!last) parts.back() += '\n';
    }
    if (last) break;
    begin = end + 1;
  }
  return parts;
}

std::optional<std::string> part(const std::vector<std::string>& parts, size_t i) {
  if (i < parts.size()) return parts[i];
  return std::nullopt;
}

namespace {

struct Scratch {
  std::string path;
  Scratch() {
    std::string base;
    if (const char* env = std::getenv("FUZZ_TMPDIR"); env && *env)
      base = env;
    else if (fs::is_directory("/dev/shm"))
      base = "/dev/shm";
    else
      base = fs::temp_directory_path().string();
    std::string pattern = base + "/relocalizer-fuzz-XXXXXX";
    if (!mkdtemp(pattern.data()))
      throw std::runtime_error("cannot make a scratch folder in " + base);
    path = pattern;
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string encodePng(const cv::Mat& image) {
  std::vector<uint8_t> bytes;
  if (!cv::imencode(".png", image, bytes)) throw std::runtime_error("cannot encode a PNG");
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

const std::string& scratchDir() {
  static Scratch scratch;
  return scratch.path;
}

void writeFile(const std::string& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(content.data(), static_cast<std::streamsize>(content.size()));
  if (!out) throw std::runtime_error("cannot write " + path);
}

void writeOrRemove(const std::string& path, const std::optional<std::string>& content) {
  if (content) {
    writeFile(path, *content);
  } else {
    std::error_code ec;
    fs::remove(path, ec);
  }
}

void makeDirs(const std::string& path) { fs::create_directories(path); }

std::string tinyColourPng() {
  cv::Mat colour(kFrameHeight, kFrameWidth, CV_8UC3);
  for (int v = 0; v < colour.rows; ++v)
    for (int u = 0; u < colour.cols; ++u)
      colour.at<cv::Vec3b>(v, u) =
          cv::Vec3b(static_cast<uint8_t>(30 * u), static_cast<uint8_t>(40 * v),
                    static_cast<uint8_t>(7 * (u + v)));
  return encodePng(colour);
}

std::string tinyDepthPng() {
  cv::Mat depth(kFrameHeight, kFrameWidth, CV_16UC1);
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
      depth.at<uint16_t>(v, u) =
          static_cast<uint16_t>(u == 0 && v == 0 ? 0 : 1000 + 50 * u + 20 * v);
  return encodePng(depth);
}

bool escapesFolder(const std::string& text) {
  if (text.find("..") != std::string::npos) return true;
  // A name starting with '/' after whitespace or at a line start is absolute.
  for (size_t i = 0; i < text.size(); ++i)
    if (text[i] == '/' &&
        (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\t' || text[i - 1] == '\n' ||
         text[i - 1] == '\r' || text[i - 1] == '\v' || text[i - 1] == '\f'))
      return true;
  return false;
}

}  // namespace relocalizer::fuzz
