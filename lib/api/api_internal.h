// Conversions between the public API's types (include/visgate/visgate.h) and the
// library's, shared by the API's implementation files (lib/api, oracle/api).
#pragma once

#include "include/visgate/visgate.h"
#include "lib/scene/scene.h"
#include "lib/solver.h"

namespace visgate::api::detail {

inline Vec3 to_api(const Vec3f& v) { return {v.x, v.y, v.z}; }
inline Vec3f from_api(const Vec3& v) { return Vec3f(v.x, v.y, v.z); }
inline Scene wrap(visgate::Scene s) { return Scene(std::make_shared<const visgate::Scene>(std::move(s))); }

// The library's result of a public solution (for the oracle's comparator).
SolveResult to_solve_result(const visgate::Scene& scene, const Solution& s);

}  // namespace visgate::api::detail
