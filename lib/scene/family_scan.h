// The `scan` family (DESIGN section 7): a dense, closed, smooth surface like a scanned
// model, standing on a ground slab, lit as paper 000's BUNNY scene. See family_scan.cpp.
#pragma once

#include "lib/scene/families.h"

namespace visgate {

// Triangles: FamilyParams::triangles (default 20,000) within a few percent for any
// target from 100 to 50M; receivers a floor grid (default 32 x 32); samples per light
// (default 36, as BUNNY). Deterministic in the parameters.
Result<Scene> gen_scan(const FamilyParams& p);

}  // namespace visgate
