// Nesting of closed shells (internal to lib/repair), as CGAL's orient_to_bound_a_volume:
// a shell inside an odd number of other shells bounds a cavity and must face inward, the
// others outward. Exact (ray parity under a symbolic perturbation, nesting.cpp).
#pragma once

#include <vector>

#include "lib/repair/mesh_topology.h"
#include "lib/repair/repair_predicates.h"

namespace visgate::mesh {

// depth[i]: how many of the other shells contain shell i (by a vertex of it; shells of a
// valid solid do not cross). Each shell is a list of triangle indices.
std::vector<int> nesting_depths(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris,
                                const std::vector<std::vector<uint32_t>>& shells, const FilteredPredicates& fp);

}  // namespace visgate::mesh
