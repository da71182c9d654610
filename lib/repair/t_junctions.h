// T-junctions (internal to lib/repair): a boundary vertex lying strictly inside a
// boundary edge. Exact: collinearity through the filtered predicates, betweenness by
// coordinate comparisons (exact on doubles).
#pragma once

#include <vector>

#include "lib/repair/mesh_topology.h"
#include "lib/repair/repair_predicates.h"

namespace visgate::mesh {

struct TJunction {
  uint32_t v, group;  // the vertex, the edge group (of `e`) it lies inside
};

// Every T-junction of the boundary edges of `e`, sorted by edge group, then vertex.
std::vector<TJunction> find_t_junctions(const std::vector<Vec3d>& pos, const EdgeTable& e,
                                        const FilteredPredicates& fp);

}  // namespace visgate::mesh
