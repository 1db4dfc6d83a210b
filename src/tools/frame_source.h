#pragma once
// Moved: the interface is relocalizer/data/frame_source.h, the tools' options
// source_arguments.h. Kept only until train.cpp includes source_arguments.h
// (its owner's change, issue 24); then delete this file.

#include "source_arguments.h"

namespace relocalizer::cli {
using relocalizer::FrameSource;
}  // namespace relocalizer::cli
