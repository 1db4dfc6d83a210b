#pragma once
// The online-learning options that `evaluate --learn-frames` and
// `learn_benchmark` share, with their help and their checks, so that both tools
// name and check them the same way (and as the node's learn_* parameters).

#include <string>

#include "cli_support.h"
#include "relocalizer/online/submap_rule.h"

namespace relocalizer::cli {

// --relearn-agreement: the node's learn_relearn_agreement.
inline Option* addRelearnAgreement(App& app, SubmapParams& rule) {
  return app
      .addOption("--relearn-agreement", rule.relearn_agreement,
                 "With --submaps: a key frame the frozen submaps cover is learned again when "
                 "less than this share of its depth lies on their surface (the place changed "
                 "there; the node's learn_relearn_agreement); 0: never")
      ->range(0.0, 1.0)
      ->showDefault();
}

// The rule relearns into frozen submaps: one store has none. Empty when fine.
inline std::string relearnAgreementError(const SubmapParams& rule, bool submaps) {
  if (submaps || rule.relearn_agreement == SubmapParams{}.relearn_agreement) return "";
  return "--relearn-agreement needs --submaps (one store has no frozen submaps to cover)";
}

}  // namespace relocalizer::cli
