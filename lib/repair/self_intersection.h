// Self-intersection of triangle meshes (internal to lib/repair): exact pair tests over
// the filtered predicates, candidates from a box tree.
#pragma once

#include <array>
#include <vector>

#include "lib/repair/mesh_topology.h"
#include "lib/repair/repair_predicates.h"

namespace visgate::mesh {

// Whether the non-degenerate triangles A and B meet beyond what they share. Corners whose
// vertices share a class (cls[v], identity when cls is null) are the same point: the
// triangles may meet there and along a shared edge without intersecting. Exact.
bool pair_intersects(const std::vector<Vec3d>& pos, const Tri& A, const Tri& B, const uint32_t* cls,
                     const FilteredPredicates& fp);

// Every intersecting pair (x < y) among the triangles with candidate[t] set, sorted;
// `pairs_tested` receives the number of candidate pairs (overlapping boxes) decided.
std::vector<std::array<uint32_t, 2>> self_intersections(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris,
                                                        const std::vector<uint8_t>& candidate, const uint32_t* cls,
                                                        const FilteredPredicates& fp, size_t& pairs_tested);

}  // namespace visgate::mesh
