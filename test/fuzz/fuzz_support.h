#pragma once
// Shared by the libFuzzer targets in this folder (see docs/reliability.md).
//
// Dataset targets take one input holding several text files: the parts are
// separated by a line that is exactly "=====" (kPartSeparator). A part that is
// absent (fewer separators) means "that file does not exist", so both the
// "optional file missing" and "file present but malformed" paths are fuzzed.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace relocalizer::fuzz {

constexpr const char* kPartSeparator = "=====";

// The parts of `data`, split on separator lines; always at least one part.
std::vector<std::string> splitParts(const uint8_t* data, size_t size);

// The i-th part, or nullopt when the input has fewer parts.
std::optional<std::string> part(const std::vector<std::string>& parts, size_t i);

// A private scratch folder for this process, made on first use under
// $FUZZ_TMPDIR (else /dev/shm, else /tmp) and removed at normal exit.
const std::string& scratchDir();

// Writes `content` to `path` when set, otherwise removes `path`, so each run
// starts from the files its own input describes.
void writeOrRemove(const std::string& path, const std::optional<std::string>& content);
void writeFile(const std::string& path, const std::string& content);
void makeDirs(const std::string& path);

// PNG bytes of a tiny valid frame (colour 8-bit BGR, depth 16-bit with valid
// values), written once per process by the dataset targets.
constexpr int kFrameWidth = 8;
constexpr int kFrameHeight = 6;
std::string tinyColourPng();
std::string tinyDepthPng();

// True when `text` could make a dataset reader look outside the scratch folder
// (absolute names, ".."), which would make runs depend on this machine's files.
bool escapesFolder(const std::string& text);

}  // namespace relocalizer::fuzz
