// The small text files of the datasets: lines, numbers, pose and intrinsics
// files, read with errors that name the file and line.

#include "dataset_text_files.h"

#include "relocalizer/core/decimal_number.h"

#include <cctype>
#include <fstream>
#include <string_view>

namespace relocalizer::detail {

Expected<std::vector<std::string>> readLines(const fs::path& file) {
  std::ifstream in(file);
  if (!in) {
    std::error_code ec;
    return makeError(file.string() + (fs::is_regular_file(file, ec)
                                          ? ": cannot be opened for reading"
                                          : ": missing"));
  }
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(std::move(line));
  }
  if (in.bad()) return makeError(file.string() + ": read error");
  return lines;
}

bool isCommentOrBlank(const std::string& line) {
  const size_t first = line.find_first_not_of(" \t");
  return first == std::string::npos || line[first] == '#';
}

Expected<std::vector<double>> parseNumbers(const std::string& line, const fs::path& file,
                                           int line_number) {
  std::vector<double> numbers;
  const char* p = line.data();
  const char* end = p + line.size();
  const auto is_space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (true) {
    while (p < end && is_space(*p)) ++p;
    if (p == end) break;
    const char* token_end = p;
    while (token_end < end && !is_space(*token_end)) ++token_end;
    const auto value = parseDecimal(std::string_view(p, token_end - p));
    if (!value)
      return makeError(file.string() + ": line " + std::to_string(line_number) + ": '" +
                       std::string(p, token_end) + "' is not a number");
    numbers.push_back(*value);
    p = token_end;
  }
  return numbers;
}

Expected<std::optional<Pose>> readPoseFile(const fs::path& file, NonFinitePose non_finite) {
  auto lines = readLines(file);
  if (!lines) return makeError(lines.error());
  Eigen::Matrix4d m;
  int rows = 0;
  for (size_t i = 0; i < lines->size(); ++i) {
    const int line_number = static_cast<int>(i) + 1;
    auto numbers = parseNumbers((*lines)[i], file, line_number);
    if (!numbers) return makeError(numbers.error());
    if (numbers->empty()) continue;  // blank lines, e.g. a trailing one
    if (rows == 4)
      return makeError(file.string() + ": line " + std::to_string(line_number) +
                       ": unexpected fifth row; expected a 4x4 matrix");
    if (numbers->size() != 4)
      return makeError(file.string() + ": line " + std::to_string(line_number) +
                       ": expected 4 numbers, got " + std::to_string(numbers->size()));
    for (int c = 0; c < 4; ++c) m(rows, c) = (*numbers)[c];
    ++rows;
  }
  if (rows != 4)
    return makeError(file.string() + ": expected a 4x4 matrix (4 lines of 4 numbers), got " +
                     std::to_string(rows) + " rows");
  if (!m.allFinite()) {
    if (non_finite == NonFinitePose::NoGroundTruth) return std::optional<Pose>();
    return makeError(file.string() + (m.hasNaN() ? ": pose contains NaN" : ": pose contains Inf"));
  }
  auto pose = poseFromMatrix(m);
  if (!pose) return makeError(file.string() + ": " + pose.error());
  return std::optional<Pose>(*pose);
}

Expected<CameraIntrinsics> readIntrinsicsFile(const fs::path& file) {
  auto lines = readLines(file);
  if (!lines) return makeError(lines.error());
  Eigen::Matrix3d k;
  int rows = 0;
  for (size_t i = 0; i < lines->size(); ++i) {
    const int line_number = static_cast<int>(i) + 1;
    auto numbers = parseNumbers((*lines)[i], file, line_number);
    if (!numbers) return makeError(numbers.error());
    if (numbers->empty()) continue;
    if (rows == 3 || numbers->size() != 3)
      return makeError(
          file.string() + ": line " + std::to_string(line_number) +
          ": expected a 3x3 camera matrix K (3 lines of 3 numbers), got " +
          (rows == 3 ? std::string("a fourth row") : std::to_string(numbers->size()) + " numbers"));
    for (int c = 0; c < 3; ++c) k(rows, c) = (*numbers)[c];
    ++rows;
  }
  if (rows != 3)
    return makeError(file.string() +
                     ": expected a 3x3 camera matrix K (3 lines of 3 numbers), got " +
                     std::to_string(rows) + " rows");
  if (!k.allFinite() || k(2, 0) != 0 || k(2, 1) != 0 || k(2, 2) != 1)
    return makeError(file.string() + ": not a camera matrix (last row must be 0 0 1)");
  CameraIntrinsics camera;
  camera.fx = k(0, 0);
  camera.fy = k(1, 1);
  camera.cx = k(0, 2);
  camera.cy = k(1, 2);
  if (std::string problem = camera.validationError(); !problem.empty())
    return makeError(file.string() + ": " + problem);
  return camera;
}

}  // namespace relocalizer::detail
