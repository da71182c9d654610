// The clean pass of repair_mesh: repeated-vertex, zero-area and duplicate faces removed,
// T-junctions split (see passes.h).
#include <algorithm>
#include <numeric>
#include <unordered_map>

#include "lib/repair/passes.h"
#include "lib/repair/repair_predicates.h"
#include "lib/repair/t_junctions.h"

namespace visgate::mesh {

namespace {

// Removes triangles with keep[t] == 0, recording `reason` for each.
void remove_triangles(Work& w, const std::vector<uint8_t>& keep, const std::vector<const char*>& reason,
                      std::vector<RemovedTriangle>& removed) {
  size_t o = 0;
  for (size_t t = 0; t < w.tris.size(); ++t) {
    if (keep[t]) {
      w.tris[o] = w.tris[t];
      w.src[o] = w.src[t];
      ++o;
    } else if (w.src[t] != kFilledHole) {
      removed.push_back({w.src[t], reason[t]});
    }
  }
  w.tris.resize(o);
  w.src.resize(o);
}

// Splits every boundary edge at the boundary vertices strictly inside it (T-junctions).
// A triangle whose edge (a, b) holds points p1..pm (ordered from a) becomes the fan
// (a, p1, c), (p1, p2, c), ..., (pm, b, c) with c its third corner; none is degenerate
// because each p lies strictly inside ab and c is off that line (zero-area triangles were
// removed before). Returns the number of points inserted.
size_t split_t_junctions(Work& w, const ExactPredicates& ex, size_t& added) {
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  std::vector<TJunction> tj = find_t_junctions(w.pos, e, FilteredPredicates(ex));
  if (tj.empty()) return 0;
  std::unordered_map<uint64_t, std::vector<uint32_t>> points;  // edge key -> points, ordered from lo
  for (const TJunction& j : tj) points[e.recs[e.start[j.group]].key].push_back(j.v);
  for (auto& [key, list] : points) {
    const Vec3d& a = w.pos[uint32_t(key >> 32)];
    const Vec3d& b = w.pos[uint32_t(key & 0xffffffffu)];
    int ax = max_axis(vabs(b - a));  // a != b on this axis: coordinate order is exact
    bool up = a[ax] < b[ax];
    std::sort(list.begin(), list.end(), [&](uint32_t p, uint32_t q) {
      return up ? w.pos[p][ax] < w.pos[q][ax] : w.pos[p][ax] > w.pos[q][ax];
    });
  }
  std::vector<uint32_t> queue(w.tris.size());
  std::iota(queue.begin(), queue.end(), 0u);
  const size_t before = w.tris.size();
  while (!queue.empty()) {
    uint32_t t = queue.back();
    queue.pop_back();
    for (int k = 0; k < 3; ++k) {
      uint32_t a = w.tris[t][size_t(k)], b = w.tris[t][size_t((k + 1) % 3)], c = w.tris[t][size_t((k + 2) % 3)];
      auto it = points.find(edge_key(a, b));
      if (it == points.end()) continue;
      std::vector<uint32_t> chain{a};
      if (a < b) chain.insert(chain.end(), it->second.begin(), it->second.end());
      else chain.insert(chain.end(), it->second.rbegin(), it->second.rend());
      chain.push_back(b);
      points.erase(it);
      uint32_t s = w.src[t];
      w.tris[t] = {chain[0], chain[1], c};
      queue.push_back(t);
      for (size_t i = 1; i + 1 < chain.size(); ++i) {
        w.tris.push_back({chain[i], chain[i + 1], c});
        w.src.push_back(s);
        queue.push_back(uint32_t(w.tris.size() - 1));
      }
      break;
    }
  }
  added = w.tris.size() - before;
  return tj.size();
}

// Removes repeated-vertex and zero-area faces and later copies of a face, counting each.
void clean_faces(Work& w, const FilteredPredicates& fp, CleanCounts& c, std::vector<RemovedTriangle>& removed) {
  const size_t nt = w.tris.size();
  std::vector<uint8_t> keep(nt, 1);
  std::vector<const char*> reason(nt, "");
  for (size_t t = 0; t < nt; ++t) {
    const Tri& f = w.tris[t];
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
      keep[t] = 0;
      reason[t] = "repeated_vertex";
      ++c.repeated;
    } else if (fp.collinear(w.pos[f[0]], w.pos[f[1]], w.pos[f[2]])) {
      keep[t] = 0;
      reason[t] = "zero_area";
      ++c.zero_area;
    }
  }
  std::vector<uint8_t> dup = find_duplicates(w.tris, keep, w.pos.size());
  for (size_t t = 0; t < nt; ++t) {
    if (dup[t] == 1) { keep[t] = 0; reason[t] = "duplicate"; ++c.duplicates; }
    if (dup[t] == 2) { keep[t] = 0; reason[t] = "opposite_duplicate"; ++c.opposite_duplicates; }
  }
  remove_triangles(w, keep, reason, removed);
}

}  // namespace

// Splitting T-junctions can recreate a face that is already there (the split of (a, b, c)
// at p yields (a, p, c), which may exist), and removing copies can open edges that hold
// T-junctions; so both run until a split finds nothing, which repair of the output then
// confirms (idempotence).
CleanCounts clean(Work& w, const ExactPredicates& ex, std::vector<RemovedTriangle>& removed) {
  const FilteredPredicates fp(ex);
  CleanCounts c;
  clean_faces(w, fp, c, removed);
  for (int round = 0; round < 16; ++round) {
    size_t added = 0;
    const size_t split = split_t_junctions(w, ex, added);
    if (split == 0) break;
    c.t_junctions += split;
    c.split_triangles += added;
    clean_faces(w, fp, c, removed);
  }
  return c;
}

StepRecord CleanCounts::record(double seconds) const {
  return {"clean",
          {{"repeated_vertex_faces_removed", repeated},
           {"zero_area_faces_removed", zero_area},
           {"duplicate_faces_removed", duplicates},
           {"opposite_duplicate_faces_removed", opposite_duplicates},
           {"t_junctions_split", t_junctions},
           {"triangles_added_by_splits", split_triangles}},
          seconds};
}

}  // namespace visgate::mesh
