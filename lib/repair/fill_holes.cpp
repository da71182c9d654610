// The fill-holes pass of repair_mesh (see passes.h).
#include <algorithm>
#include <limits>
#include <unordered_map>

#include "lib/mesh/box_tree.h"
#include "lib/repair/passes.h"
#include "lib/repair/repair_predicates.h"
#include "lib/repair/self_intersection.h"

namespace visgate::mesh {

namespace {

// Hash of a face's vertex set (a proposal only: equal sorted triples decide).
uint64_t face_hash(const Tri& t) {
  const auto k = sorted3(t);
  return uint64_t(k[0]) * 0x9E3779B97F4A7C15ull ^ (uint64_t(k[1]) << 32 | k[2]);
}

// Minimum-area triangulation of the closed polygon `poly` (Liepa's dynamic program over
// sub-polygons, O(n^3)): a float proposal, checked exactly by the caller. Triangles
// whose sides would reuse an existing mesh edge as a chord (`is_edge`) are not allowed.
// Returns false when no triangulation avoids them. Triangles follow the polygon's order.
template <class IsEdge>
bool min_area_triangulation(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& poly, IsEdge&& is_edge,
                            std::vector<Tri>& out) {
  const size_t n = poly.size();
  const double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> W(n * n, 0.0);
  std::vector<uint32_t> K(n * n, kNone);
  auto area = [&](size_t i, size_t k, size_t j) {
    return 0.5 * length(cross(pos[poly[k]] - pos[poly[i]], pos[poly[j]] - pos[poly[i]]));
  };
  // A chord (i, j), j > i + 1 and not the closing pair (0, n-1), must not be a mesh edge.
  auto chord_ok = [&](size_t i, size_t j) { return j == i + 1 || (i == 0 && j == n - 1) || !is_edge(poly[i], poly[j]); };
  for (size_t len = 2; len < n; ++len)
    for (size_t i = 0; i + len < n; ++i) {
      const size_t j = i + len;
      double best = kInf;
      uint32_t arg = kNone;
      if (chord_ok(i, j))
        for (size_t k = i + 1; k < j; ++k) {
          const double c = W[i * n + k] + W[k * n + j] + area(i, k, j);
          if (c < best) { best = c; arg = uint32_t(k); }
        }
      W[i * n + j] = best;
      K[i * n + j] = arg;
    }
  if (K[n - 1] == kNone) return false;
  std::vector<std::pair<size_t, size_t>> stack{{0, n - 1}};
  while (!stack.empty()) {
    auto [i, j] = stack.back();
    stack.pop_back();
    if (j < i + 2) continue;
    const size_t k = K[i * n + j];
    if (k == kNone) return false;
    out.push_back({poly[i], poly[k], poly[j]});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
  return true;
}

// Why a fill cannot be applied, or nullptr when every check passes: each triangle is
// non-degenerate, no triangle repeats a face of the mesh or of the fill (in either
// orientation), no chord is a mesh edge or used by more than two fill triangles, and no
// triangle meets a mesh triangle or another fill triangle beyond their shared vertices
// and edges (exact).
const char* fill_defect(const std::vector<Vec3d>& pos, const std::vector<Tri>& fill, const std::vector<Tri>& tris,
                        const BoxTree& tree, const std::vector<Box3d>& boxes,
                        const std::unordered_map<uint64_t, uint32_t>& edge_count,
                        const std::unordered_map<uint64_t, uint8_t>& faces, const FilteredPredicates& fp) {
  for (const Tri& t : fill)
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || fp.collinear(pos[t[0]], pos[t[1]], pos[t[2]]))
      return "degenerate_triangle";
  // Faces: the hash only proposes; the sorted triples decide.
  for (size_t i = 0; i < fill.size(); ++i) {
    if (faces.count(face_hash(fill[i])))
      for (const Tri& m : tris)
        if (sorted3(m) == sorted3(fill[i])) return same_orientation(m, fill[i]) ? "duplicate_face" : "opposite_duplicate_face";
    for (size_t j = 0; j < i; ++j)
      if (sorted3(fill[j]) == sorted3(fill[i]))
        return same_orientation(fill[j], fill[i]) ? "duplicate_face" : "opposite_duplicate_face";
  }
  // Edges: a fill edge already in the mesh may gain one face (a loop edge); any other
  // use would make it non-manifold.
  std::unordered_map<uint64_t, uint32_t> added;
  for (const Tri& t : fill)
    for (int k = 0; k < 3; ++k) ++added[edge_key(t[size_t(k)], t[size_t((k + 1) % 3)])];
  for (const auto& [key, n] : added) {
    auto it = edge_count.find(key);
    const uint32_t have = it == edge_count.end() ? 0 : it->second;
    if (have + n > 2) return "nonmanifold_edge";
  }
  // Intersections with the mesh and within the fill.
  for (size_t i = 0; i < fill.size(); ++i) {
    const Tri& t = fill[i];
    Box3d b{pos[t[0]], pos[t[0]]};
    b.extend(pos[t[1]]);
    b.extend(pos[t[2]]);
    bool hit = false;
    tree.query(b, [&](uint32_t m) {
      if (!hit && boxes_overlap(boxes[m], b) && pair_intersects(pos, t, tris[m], nullptr, fp)) hit = true;
    });
    if (hit) return "self_intersection";
    for (size_t j = 0; j < i; ++j)
      if (pair_intersects(pos, fill[j], t, nullptr, fp)) return "self_intersection";
  }
  return nullptr;
}

// Closed loops that pass a vertex more than once (two holes meeting at a vertex) split
// there into simple cycles, each a hole of its own; chains and simple loops stay as they
// are. A cycle of two edges (an edge walked there and back) is dropped: it bounds nothing.
std::vector<Loop> simple_loops(std::vector<Loop> loops) {
  std::vector<Loop> out;
  std::unordered_map<uint32_t, size_t> at;  // vertex -> index in the current path
  for (Loop& L : loops) {
    if (!L.closed) {
      out.push_back(std::move(L));
      continue;
    }
    const size_t n = L.groups.size();
    std::vector<uint32_t> path{L.verts[0]}, edges;
    at.clear();
    at[L.verts[0]] = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t next = L.verts[(i + 1) % n];
      edges.push_back(L.groups[i]);
      auto it = at.find(next);
      if (it == at.end()) {
        at[next] = path.size();
        path.push_back(next);
        continue;
      }
      const size_t j = it->second;
      Loop C;
      C.verts.assign(path.begin() + long(j), path.end());
      C.groups.assign(edges.begin() + long(j), edges.end());
      if (C.groups.size() >= 3) out.push_back(std::move(C));
      for (size_t k = j + 1; k < path.size(); ++k) at.erase(path[k]);
      path.resize(j + 1);
      edges.resize(j);
    }
  }
  return out;
}

// Fills closed boundary loops of at most `max_len` edges that are simple and
// consistently directed: the minimum-area triangulation of the loop traversed against
// its faces' direction, or else its ear-clipping triangulation, whichever first passes
// every exact check of fill_defect; a loop that neither passes is left open, recorded
// with the first candidate's reason. Fills accepted earlier count as mesh for later ones.
void fill_once(Work& w, size_t max_len, const ExactPredicates& ex, std::vector<HoleRecord>& holes, size_t& added,
               size_t& longer) {
  const FilteredPredicates fp(ex);
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  std::vector<Loop> loops = simple_loops(boundary_loops(e));
  std::unordered_map<uint64_t, uint32_t> edge_count;
  std::unordered_map<uint64_t, uint8_t> faces;
  bool any = false;
  for (const Loop& L : loops) any = any || (L.closed && L.groups.size() <= max_len && L.groups.size() >= 3);
  if (!any) {
    for (const Loop& L : loops) longer += L.closed && L.groups.size() > max_len;
    return;
  }
  for (size_t g = 0; g < e.groups(); ++g) edge_count[e.recs[e.start[g]].key] = e.size(g);
  for (const Tri& t : w.tris) faces[face_hash(t)] = 1;
  // A tree of the mesh's triangles; fills accepted later are appended to w.tris and
  // tested directly, outside the tree.
  const size_t base = w.tris.size();
  std::vector<Box3d> boxes(base);
  for (size_t t = 0; t < base; ++t) {
    boxes[t] = Box3d{w.pos[w.tris[t][0]], w.pos[w.tris[t][0]]};
    boxes[t].extend(w.pos[w.tris[t][1]]);
    boxes[t].extend(w.pos[w.tris[t][2]]);
  }
  BoxTree tree(boxes);
  constexpr size_t kMaxTriangulated = 2000;  // the O(n^3) program takes seconds at this size
  for (const Loop& L : loops) {
    const size_t n = L.groups.size();
    if (!L.closed || n < 3) continue;
    if (n > max_len) { ++longer; continue; }
    HoleRecord rec;
    rec.edges = n;
    std::vector<uint32_t> sorted(L.verts);
    std::sort(sorted.begin(), sorted.end());
    const bool simple = std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end();
    // Direction of each edge in its face: along the loop (verts[i] -> verts[i+1]) or not.
    int along = 0;
    for (size_t i = 0; i < n; ++i) {
      const EdgeRec& r = e.recs[e.start[L.groups[i]]];
      along += w.tris[r.tri][r.k] == L.verts[i] ? 1 : -1;
    }
    if (!simple) rec.reason = "not_simple";
    else if (along != int(n) && along != -int(n)) rec.reason = "inconsistent_direction";
    else if (n > kMaxTriangulated) rec.reason = "too_long_to_triangulate";
    if (rec.reason) {
      holes.push_back(rec);
      continue;
    }
    // The candidates are computed on the loop in a canonical order (from its lowest
    // vertex, towards the lower neighbour), so that they do not depend on where the walk
    // started or on the faces' orientation, then turned to run against the faces.
    std::vector<uint32_t> poly(L.verts);
    std::rotate(poly.begin(), std::min_element(poly.begin(), poly.end()), poly.end());
    if (poly[n - 1] < poly[1]) std::reverse(poly.begin() + 1, poly.end());
    const size_t at0 = size_t(std::find(L.verts.begin(), L.verts.end(), poly[0]) - L.verts.begin());
    const bool walk_order = L.verts[(at0 + 1) % n] == poly[1];
    const bool flip = walk_order == (along > 0);  // the fill runs against the faces' direction
    auto is_edge = [&](uint32_t a, uint32_t b) {
      return edge_count.count(edge_key(a, b)) > 0;
    };
    std::vector<std::vector<Tri>> candidates(2);
    if (!min_area_triangulation(w.pos, poly, is_edge, candidates[0])) candidates[0].clear();
    triangulate_polygon(w.pos, poly, candidates[1]);
    if (flip)
      for (auto& fill : candidates)
        for (Tri& t : fill) std::swap(t[1], t[2]);
    const std::vector<Tri>* chosen = nullptr;
    for (const auto& fill : candidates) {
      if (fill.empty()) {
        if (!rec.reason) rec.reason = "chord_is_an_edge";
        continue;
      }
      const char* why = fill_defect(w.pos, fill, w.tris, tree, boxes, edge_count, faces, fp);
      // Fills accepted before this one are not in the tree: test them directly.
      for (size_t t = base; t < w.tris.size() && !why; ++t)
        for (const Tri& f : fill)
          if (pair_intersects(w.pos, f, w.tris[t], nullptr, fp)) { why = "self_intersection"; break; }
      if (!why) { chosen = &fill; break; }
      if (!rec.reason) rec.reason = why;
    }
    if (!chosen) {
      holes.push_back(rec);
      continue;
    }
    rec.filled = true;
    rec.reason = nullptr;
    rec.triangles = chosen->size();
    for (const Tri& t : *chosen) {
      w.tris.push_back(t);
      w.src.push_back(kFilledHole);
      faces[face_hash(t)] = 1;
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = t[size_t(k)], b = t[size_t((k + 1) % 3)];
        ++edge_count[edge_key(a, b)];
      }
    }
    added += chosen->size();
    holes.push_back(rec);
  }
}

}  // namespace

// Passes until one fills nothing: a fill can change the boundary walk and the geometry
// later loops are checked against, and repair of the output must find nothing more to
// fill (idempotence). `holes` keeps every fill and the last pass's open loops; filled
// components are oriented again.
FillCounts fill_holes(Work& w, size_t max_len, const ExactPredicates& ex, std::vector<HoleRecord>& holes) {
  FillCounts c;
  for (int pass = 0; pass < 8; ++pass) {
    std::vector<HoleRecord> found;
    c.loops_longer_than_limit = 0;
    fill_once(w, max_len, ex, found, c.triangles_added, c.loops_longer_than_limit);
    size_t now = 0;
    for (const HoleRecord& h : found) now += h.filled;
    c.loops_filled += now;
    std::vector<HoleRecord> kept;
    for (const HoleRecord& h : holes)
      if (h.filled) kept.push_back(h);
    for (const HoleRecord& h : found)
      if (h.filled || now == 0) kept.push_back(h);
    holes = std::move(kept);
    if (now == 0) break;
  }
  const OrientCounts again = c.loops_filled ? orient(w, ex) : OrientCounts{};
  c.loops_not_fillable = holes.size() - c.loops_filled;
  c.faces_flipped_after_filling = again.consistency_flips + again.outward_flips;
  return c;
}

StepRecord FillCounts::record(double seconds) const {
  return {"fill_holes",
          {{"loops_filled", loops_filled},
           {"triangles_added", triangles_added},
           {"loops_not_fillable", loops_not_fillable},
           {"loops_longer_than_limit", loops_longer_than_limit},
           {"faces_flipped_after_filling", faces_flipped_after_filling}},
          seconds};
}

}  // namespace visgate::mesh
