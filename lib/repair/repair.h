// Mesh repair and welding for `visgate repair` (DESIGN section 7): polygon
// triangulation, welding by true Euclidean distance, cleaning (repeated-vertex,
// zero-area and duplicate faces, T-junction splitting), consistent and outward
// orientation, topology report (non-manifold edges and vertices, boundary loops,
// components, genus), optional hole filling and non-manifold splitting, and exact
// self-intersection detection.
//
// Guarantee: every combinatorial decision that depends on geometry is exact. Float
// (double) code only proposes candidates (spatial hashing cells, bounding-box overlaps,
// ear-clipping order); every decision goes through ExactPredicates, which the caller
// implements exactly (cgal_predicates.h does it with CGAL, the only file of lib/repair
// that includes CGAL), behind the double filters of repair_predicates.h, which answer
// only when a proven error bound makes the sign certain:
//   - welding: |p - q| <= T decided exactly (compare_distance);
//   - zero area: exact collinearity of the three corners;
//   - T-junctions: exact collinearity plus exact coordinate comparisons;
//   - outward orientation: exact sign of the enclosed volume, and exact nesting of closed
//     shells (ray parity under a symbolic perturbation) so that cavities face inward;
//   - self-intersection: exact triangle-triangle, segment-triangle and orientation tests.
// No vertex is ever moved: a welded vertex takes the position of its lowest-index input
// vertex, so output coordinates are input coordinates bit for bit.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lib/repair/mesh_write.h"
#include "lib/scene/mesh_io.h"

namespace visgate::mesh {

// Exact geometric predicates on double coordinates (every double is a dyadic rational,
// so these are predicates on the very input values).
class ExactPredicates {
 public:
  virtual ~ExactPredicates() = default;
  // True iff a, b, c lie on one line (coincident points included).
  virtual bool collinear(const Vec3d& a, const Vec3d& b, const Vec3d& c) const = 0;
  // Sign of det[b - a, c - a, d - a]: +1, 0 (coplanar) or -1.
  virtual int orientation(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) const = 0;
  // For coplanar a, b, p, q with a, b, p not collinear: +1 when q is on the same side of
  // line ab as p, 0 when q is on the line, -1 on the other side.
  virtual int coplanar_side(const Vec3d& a, const Vec3d& b, const Vec3d& p, const Vec3d& q) const = 0;
  // Closed segment [s0, s1] meets closed triangle (t0, t1, t2).
  virtual bool segment_triangle_intersect(const Vec3d& s0, const Vec3d& s1, const Vec3d& t0, const Vec3d& t1,
                                          const Vec3d& t2) const = 0;
  // Closed triangles (a0, a1, a2) and (b0, b1, b2) meet.
  virtual bool triangles_intersect(const Vec3d& a0, const Vec3d& a1, const Vec3d& a2, const Vec3d& b0,
                                   const Vec3d& b1, const Vec3d& b2) const = 0;
  // Sign of |p - q| - t (t >= 0).
  virtual int compare_distance(const Vec3d& p, const Vec3d& q, double t) const = 0;
  // Sign of the signed volume enclosed by the triangles `subset` of (v, tris): the sum
  // over triangles of det[b - o, c - o, d - o] for a fixed point o (for a closed surface
  // the sum does not depend on o). +1: counter-clockwise triangles face outward.
  virtual int volume_sign(const std::vector<Vec3d>& v, const std::vector<std::array<uint32_t, 3>>& tris,
                          const std::vector<uint32_t>& subset) const = 0;
};

enum class WeldMode { Chain, Strict };

struct RepairOptions {
  double weld_tolerance = 0.0;  // T >= 0; 0 merges exactly equal positions only
  WeldMode weld_mode = WeldMode::Chain;
  bool split_nonmanifold = false;
  size_t fill_holes = 0;  // fill boundary loops of at most this many edges; 0: off
  bool check_only = false;  // analyse the input only; no repair steps run
};

// Defects, counted on a mesh by its own vertex indices. Every field is a defect: a
// repaired mesh is clean when all are zero.
struct DefectCounts {
  size_t near_duplicate_vertices = 0;   // vertices within T of another one (welding merges them)
  size_t repeated_vertex_faces = 0;     // triangles using one vertex twice
  size_t zero_area_faces = 0;           // exactly collinear corners
  size_t duplicate_faces = 0;           // same vertices, same orientation as an earlier face
  size_t opposite_duplicate_faces = 0;  // same vertices, opposite orientation
  size_t t_junctions = 0;               // boundary vertex strictly inside a boundary edge
  size_t nonmanifold_edges = 0;         // edges with three or more faces
  size_t nonmanifold_vertices = 0;      // more than one fan (not counting ends of non-manifold edges)
  size_t inconsistent_edges = 0;        // two-face edges traversed twice in one direction
  size_t nonorientable_components = 0;  // components admitting no consistent orientation
  size_t inward_components = 0;         // closed, consistent, facing against its nesting: an outer
                                        // shell with negative volume or a cavity with positive
  size_t zero_volume_components = 0;    // closed, consistently oriented, exactly zero volume
  size_t boundary_loops = 0;            // holes
  size_t self_intersections = 0;        // pairs of faces meeting beyond shared vertices/edges

  std::vector<std::pair<const char*, size_t>> items() const;
  size_t total() const;
};

struct ComponentInfo {
  size_t faces = 0, vertices = 0, edges = 0, boundary_loops = 0;
  bool closed = false;      // no boundary and no non-manifold edge
  bool orientable = true;   // no parity conflict across two-face edges
  bool consistent = true;   // no inconsistent edge
  int volume_sign = 0;      // closed and consistent only
  int depth = -1;           // shells (volume_sign != 0): how many other shells contain it;
                            // odd depth is a cavity, which faces inward
  int genus = -1;           // -1 where undefined (non-orientable or non-manifold)
};

struct Analysis {
  DefectCounts defects;
  size_t vertices = 0, triangles = 0, edges = 0, boundary_edges = 0, closed_components = 0;
  size_t cavities = 0;  // shells at odd nesting depth
  std::vector<ComponentInfo> components;
  std::vector<std::vector<uint32_t>> boundary_loops;     // vertex sequences
  std::vector<std::array<uint32_t, 2>> nonmanifold_edges;  // vertex pairs
  std::vector<uint32_t> nonmanifold_vertices;
  std::vector<std::array<uint32_t, 3>> t_junctions;       // vertex, edge end, edge end
  std::vector<std::array<uint32_t, 2>> self_intersections;  // triangle index pairs
  size_t self_intersection_pairs_tested = 0;  // candidate pairs (overlapping boxes) decided exactly
  std::vector<std::pair<const char*, double>> seconds;  // wall time of each phase of the analysis
};

// Analyses `m` by its own indices. `vertex_class` (optional, one entry per vertex) names
// vertices that are copies of one point (split non-manifold vertices): triangles sharing
// a class share that corner for the self-intersection test.
Analysis analyze_mesh(const IndexedMesh& m, const ExactPredicates& ex, const std::vector<uint32_t>* vertex_class = nullptr);

// Polygon triangulation by ear clipping in the plane of the Newell normal (double
// orientation tests: a float proposal; every produced triangle is later checked exactly
// for zero area). Falls back to a fan when no ear is found (self-intersecting polygons);
// returns false then. Triangles keep the polygon's orientation.
bool triangulate_polygon(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& poly,
                         std::vector<std::array<uint32_t, 3>>& out);

struct WeldCluster {
  std::vector<uint32_t> vertices;  // input vertex indices, ascending
  double diameter = 0.0;           // largest pairwise distance (double estimate)
  bool exceeds_tolerance = false;  // some pair is farther apart than T (exact)
};

struct WeldResult {
  std::vector<uint32_t> rep;  // per input vertex: its representative (lowest index of its cluster)
  size_t merged = 0;          // vertices merged away
  size_t clusters = 0;        // clusters of two or more vertices
  std::vector<WeldCluster> chained;  // clusters whose diameter exceeds T (chain mode) or that
                                     // strict mode split (their members before splitting)
  size_t strict_splits = 0;          // extra clusters strict mode created
};

// Welds the vertices flagged in `used` by exact Euclidean distance: spatial hashing with
// cells of at least T, pairs with |p - q| <= T (exact) joined by union-find. Chain mode
// merges whole chains; strict mode splits a chained cluster greedily (ascending index)
// into groups whose members are pairwise within T.
WeldResult weld_vertices_exact(const std::vector<Vec3d>& pos, const std::vector<uint8_t>& used, double tolerance,
                               WeldMode mode, const ExactPredicates& ex);

constexpr uint32_t kFilledHole = 0xffffffffu;  // source of a triangle added by hole filling

struct StepRecord {
  std::string name;
  std::vector<std::pair<std::string, size_t>> changes;
  double seconds = 0.0;
};

struct RemovedTriangle {
  uint32_t face = 0;  // input face index
  const char* reason = "";  // "short_face", "repeated_vertex", "zero_area", "duplicate", "opposite_duplicate"
};

// A boundary loop that hole filling considered (closed, at most N edges).
struct HoleRecord {
  size_t edges = 0;
  bool filled = false;
  size_t triangles = 0;          // added when filled
  const char* reason = nullptr;  // when left open: "not_simple", "inconsistent_direction",
                                 // "too_long_to_triangulate", "chord_is_an_edge",
                                 // "degenerate_triangle", "duplicate_face",
                                 // "opposite_duplicate_face", "nonmanifold_edge",
                                 // "self_intersection"
};

struct RepairResult {
  IndexedMesh output;                    // after repair (the input, welded exactly, with check_only)
  std::vector<uint32_t> output_source;   // per output triangle: input face, or kFilledHole;
                                         // non-decreasing, hole fillers last
  std::vector<uint32_t> output_vertex_class;  // per output vertex: the vertex before splitting
  size_t input_vertices = 0, input_faces = 0, input_triangles = 0;
  size_t polygons_triangulated = 0, fan_fallbacks = 0, unreferenced_vertices = 0;
  size_t repeated_cycles_collapsed = 0;  // polygons listing their vertex cycle k > 1 times, kept once
  Analysis before, after;                // `after` is left empty with check_only
  WeldResult weld;
  std::vector<StepRecord> steps;
  std::vector<RemovedTriangle> removed;  // every input triangle not in the output, with its reason
  size_t faces_in_output = 0, faces_removed = 0;  // input faces with some / no triangle in the output
  std::vector<uint32_t> before_source;   // per triangle of the `before` mesh: its input face
  std::vector<HoleRecord> holes;         // with fill_holes: every loop considered, in loop order
};

// The whole repair (or, with check_only, the analysis of the input). Errors only for
// bad options (negative or non-finite tolerance), indices that exceed the vertex count,
// or a soup without any face of three or more vertices ("no faces").
Result<RepairResult> repair_mesh(const PolygonSoup& soup, const RepairOptions& opt, const ExactPredicates& ex);

}  // namespace visgate::mesh
