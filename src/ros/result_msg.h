#pragma once
// The ~result message type, under the C++ name relocalizer::RelocalizationResultMsg.
//
// gencpp puts msg/RelocalizationResult.msg into the package namespace as
// relocalizer::RelocalizationResult, the name the core already uses for the
// facade's return struct, so one translation unit cannot see both. Renaming
// the typedef here changes only the C++ spelling: the message's name on the
// wire ("relocalizer/RelocalizationResult"), its MD5 and its template
// relocalizer::RelocalizationResult_ are untouched. Include this header instead
// of the generated one, and drop it once the core struct is renamed.

#ifdef RelocalizationResult
#error "RelocalizationResult is already a macro"
#endif
#define RelocalizationResult RelocalizationResultMsg
#include <relocalizer/RelocalizationResult.h>
#undef RelocalizationResult
