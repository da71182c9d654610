// The passes of repair_mesh (internal to lib/repair; the pipeline is in repair.cpp).
// Each pass changes the working mesh and returns its counts, which become one step of
// the report (StepRecord) under the names its record() gives them.
#pragma once

#include <string>
#include <vector>

#include "lib/repair/mesh_topology.h"
#include "lib/repair/repair.h"

namespace visgate::mesh {

// The mesh being repaired: triangles with their input face (kFilledHole for fillers).
struct Work {
  std::vector<Vec3d> pos;
  std::vector<Tri> tris;
  std::vector<uint32_t> src;  // input face per triangle
};

// Triangulate: polygons by ear clipping (triangulate.cpp), a repeated vertex cycle once.
struct TriangulateCounts {
  size_t polygons_triangulated = 0, triangles_from_polygons = 0, fan_fallbacks = 0, repeated_cycles_collapsed = 0,
         short_faces_dropped = 0;
  StepRecord record(double seconds) const;
};
// Fills w.tris and w.src from the faces of `soup` (w.pos already holds its vertices);
// faces of fewer than three vertices are recorded in `removed`. Errors: an index out of
// range, or no face of three or more vertices.
Result<TriangulateCounts> triangulate_faces(const PolygonSoup& soup, Work& w, std::vector<RemovedTriangle>& removed);

// Clean (clean.cpp): repeated-vertex, zero-area and duplicate faces removed, T-junctions
// split, until a split finds nothing.
struct CleanCounts {
  size_t repeated = 0, zero_area = 0, duplicates = 0, opposite_duplicates = 0, t_junctions = 0, split_triangles = 0;
  StepRecord record(double seconds) const;
};
CleanCounts clean(Work& w, const ExactPredicates& ex, std::vector<RemovedTriangle>& removed);

// Orient (orient.cpp): consistent per patch, closed patches outward (cavities inward).
struct OrientCounts {
  size_t consistency_flips = 0, outward_components = 0, outward_flips = 0, nonorientable_skipped = 0, cavities = 0;
  StepRecord record(double seconds) const;
};
OrientCounts orient(Work& w, const ExactPredicates& ex);

// Fill holes (fill_holes.cpp): loops of at most `max_len` edges, passes until one fills
// nothing; `holes` receives every fill and the last pass's open loops.
struct FillCounts {
  size_t loops_filled = 0, triangles_added = 0, loops_not_fillable = 0, loops_longer_than_limit = 0,
         faces_flipped_after_filling = 0;
  StepRecord record(double seconds) const;
};
FillCounts fill_holes(Work& w, size_t max_len, const ExactPredicates& ex, std::vector<HoleRecord>& holes);

}  // namespace visgate::mesh
