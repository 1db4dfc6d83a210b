#pragma once
// Whether text from a peer (a place name, a path in a service request) may
// be quoted in an answer or a log line as it is: valid UTF-8 (ROS strings may
// hold any bytes, and an answer's consumer may reject what is not UTF-8)
// without control characters (a newline would forge a second log line).

#include <string_view>

namespace relocalizer {

bool printableText(std::string_view text);

}  // namespace relocalizer
