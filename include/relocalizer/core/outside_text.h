#pragma once
// Text from outside (service requests, messages, parameters) on its way into
// names, logs and answers (issue 38, W1-W5: control characters, 10,000-byte
// names and invalid UTF-8 went out raw).
//
// A name (a place's, a group's) or a frame id is 1 to kMaxNameBytes bytes of
// ASCII letters, digits and `_ - . /`, as ROS graph names and TF frame ids are
// written (`-` and `.` too: model file stems, which name places, carry them),
// with no empty part: no `/` at either end, no `//`. A frame's leading slashes
// are stripped before (tf2 rejects them; tf1 wrote them).

#include <cstddef>
#include <string>

namespace relocalizer {

constexpr size_t kMaxNameBytes = 128;

// Why `text` is no name or frame id; empty when it is one. `what` names the
// field ("name", "map_frame"); the reason quotes an excerpt of the text.
std::string nameError(const std::string& text, const std::string& what);

// `text` as one printable line: control characters and bytes that are not
// UTF-8 become '?', and text longer than max_bytes is cut at a character's
// start, its length said ("... (10000 bytes)").
std::string textExcerpt(const std::string& text, size_t max_bytes);

// Whether `text` may be quoted in an answer or a log line as it is: valid
// UTF-8 (ROS strings may hold any bytes, and an answer's consumer may reject
// what is not UTF-8) without control characters (a newline would forge a
// second log line).
bool printableText(const std::string& text);

}  // namespace relocalizer
