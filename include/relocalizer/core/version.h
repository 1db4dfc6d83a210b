#pragma once
// Written into model files and result summaries so numbers can be traced to code.
namespace relocalizer {
constexpr const char* kSoftwareVersion = "relocalizer 0.1.0";
}
