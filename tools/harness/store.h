// Turning a mismatch into a stored corpus case (`visgate check --store`,
// `visgate minimize`): minimise it (minimize.h), classify it and write the entry
// (corpus.h) with its provenance.
#pragma once

#include <string>

#include "tools/harness/check.h"
#include "tools/harness/corpus.h"
#include "tools/harness/minimize.h"

namespace visgate::harness {

// The family a scene name comes from ("shared-edge-fan-3" -> "shared-edge-fan"), or
// "other" when no family name is a prefix.
std::string family_from_scene_name(const std::string& name);

struct StoredCase {
  std::string path;
  CaseInfo info;
  MinimizeResult minimized;
};

// Minimises relation (spec.receiver, spec.light, spec.sample) of `scene` for spec.method
// and writes the entry under `root`. `base` supplies the provenance and the status and
// note of the entry (its relation fields are filled in here); an empty note is replaced
// by a generated one.
Result<StoredCase> minimize_and_store(const Scene& scene, const CaseSpec& spec, const CaseInfo& base,
                                      const std::string& root);

}  // namespace visgate::harness
