// The blocker storage (paper 000 sections 4.4.2 and 4.13; see blockers.h for the scheme
// and the guarantee): the workspace and surface pool, bounds, and validate(). The
// operations live in one file per step: triangle_surface.cpp (4.7.1 with the clipping of
// 4.5), patch_refinement.cpp (4.7.2-4.7.5), surface_combination.cpp (4.7.6, 4.7.7),
// blocking.cpp (clamping of 4.5, the blocking test of 4.6 and BLOCKS-RAY of 4.10).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"

namespace visgate::iss {

// Removes raw edges with no neighbour and renumbers the edge references.
void compact_raw(Surface& s, Workspace& ws) {
  ws.remap.assign(s.raw.size(), -1);
  size_t w = 0;
  for (size_t i = 0; i < s.raw.size(); ++i) {
    if (s.raw[i].nb[0] == kNoPatch && s.raw[i].nb[1] == kNoPatch) continue;
    ws.remap[i] = int32_t(w);
    if (w != i) s.raw[w] = s.raw[i];
    ++w;
  }
  s.raw.resize(w);
  for (Edge& e : s.edges) e.raw = uint32_t(ws.remap[e.raw]);
}

void Workspace::reset_labels(size_t n) {
  if (label_slot.size() < n) {
    label_slot.assign(n, -1);
    label_stamp.assign(n, 0);
  }
  ++stamp;
}

Surface Workspace::take_surface(size_t expect_raw) {
  if (expect_raw > kMaxSpareEdges) {
    // The large surface, with room for what the caller expects reserved here: its
    // arrays then come back to recycle() above kMaxSpareEdges whatever the surface's
    // final size, and the next large construction writes into pages already touched.
    // (Left to grow from a pooled surface, a construction that ended at kMaxSpareEdges
    // went to the small pool, and every light's initial shaft touched fresh pages.)
    Surface s;
    if (big.raw.capacity() > kMaxSpareEdges) {
      big_charge.set(0);
      s = std::move(big);  // leaves `big` empty (moved-from vectors are empty)
    } else if (!spare.empty()) {
      s = std::move(spare.back());
      spare.pop_back();
    }
    // A quarter more than asked: the next light's initial shaft, a little larger, then
    // fits too instead of reallocating into fresh pages (reserve() touches none).
    if (s.raw.capacity() < expect_raw) s.raw.reserve(expect_raw + expect_raw / 4);
    if (s.edges.capacity() < expect_raw) s.edges.reserve(expect_raw + expect_raw / 4);
    if (s.patches.capacity() < expect_raw / 3) s.patches.reserve((expect_raw + expect_raw / 4) / 3);
    return s;
  }
  if (spare.empty()) return Surface{};
  Surface s = std::move(spare.back());
  spare.pop_back();
  return s;
}

namespace {
void clear_surface(Surface& s) {
  s.raw.clear();
  s.edges.clear();
  s.patches.clear();
  s.loose.clear();
  s.box = empty_box();
  s.hull = empty_box();
  s.vsum = Vec3d(0, 0, 0);
  s.vcount = 0;
  s.refined = true;
  s.unchanged = false;
}
}  // namespace

void Workspace::recycle(Surface&& s) {
  if (s.raw.capacity() == 0 && s.edges.capacity() == 0) return;  // a moved-from husk
  if (s.raw.capacity() > kMaxSpareEdges || s.edges.capacity() > 2 * kMaxSpareEdges) {
    if (s.raw.capacity() <= big.raw.capacity()) return;  // let it go
    clear_surface(s);
    big = std::move(s);
    big_charge.set(big.bytes());
    return;
  }
  if (spare.size() >= kMaxSpare) return;
  clear_surface(s);
  spare.push_back(std::move(s));
}

void compute_bounds(Surface& s, const ShaftGeometry& g) {
  s.box = empty_box();
  s.vsum = Vec3d(0, 0, 0);
  s.vcount = 0;
  for (const RawEdge& re : s.raw) {
    s.box.extend(re.v[0]);
    s.box.extend(re.v[1]);
    if (re.inside) {
      s.vsum += re.v[0] + re.v[1];
      s.vcount += 2;
    }
  }
}

bool all_edges_outside(const Surface& s) {
  for (const RawEdge& re : s.raw)
    if (re.inside) return false;
  return true;
}

std::string validate(const Surface& s, const mesh::PreparedMesh* m) {
  auto fail = [](const std::string& w) { return "iss surface invalid: " + w; };
  int32_t np = int32_t(s.patches.size());
  std::vector<int> refs(s.raw.size() * 2, 0);
  for (size_t i = 0; i < s.raw.size(); ++i) {
    const RawEdge& re = s.raw[i];
    for (int k = 0; k < 2; ++k)
      if (re.nb[k] < kNoPatch || re.nb[k] >= np) return fail("raw edge " + std::to_string(i) + " neighbour out of range");
    if (re.nb[0] == kNoPatch && re.nb[1] == kNoPatch) return fail("raw edge " + std::to_string(i) + " has no patch");
    if (m && re.mesh_edge >= int32_t(m->edge_count())) return fail("raw edge label out of range");
    if (re.mesh_edge < kClipEdge) return fail("raw edge label negative");
  }
  std::vector<Vec3d> starts, ends;
  for (int32_t pi = 0; pi < np; ++pi) {
    const Patch& p = s.patches[size_t(pi)];
    if (p.count == 0) return fail("patch " + std::to_string(pi) + " without edges");
    if (size_t(p.first) + p.count > s.edges.size()) return fail("patch edge range out of bounds");
    if (p.facing == Facing::Inconsistent && p.tri < 0) return fail("inconsistent patch without triangle");
    starts.clear();
    ends.clear();
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Edge& e = s.edges[k];
      if (e.raw >= s.raw.size()) return fail("edge raw index out of range");
      if (edge_owner(s, e) != pi) return fail("edge of patch " + std::to_string(pi) + " not owned by it");
      ++refs[size_t(e.raw) * 2 + (e.flipped ? 0 : 1)];
      starts.push_back(edge_vertex(s, e, 0));
      ends.push_back(edge_vertex(s, e, 1));
    }
    // The edges form closed loops: every vertex starts as many edges as it ends.
    std::sort(starts.begin(), starts.end(), lex_less);
    std::sort(ends.begin(), ends.end(), lex_less);
    if (starts != ends) return fail("edges of patch " + std::to_string(pi) + " do not form loops");
  }
  for (size_t i = 0; i < s.raw.size(); ++i)
    for (int k = 0; k < 2; ++k) {
      int want = s.raw[i].nb[k] != kNoPatch ? 1 : 0;
      if (refs[i * 2 + size_t(k)] != want)
        return fail("raw edge " + std::to_string(i) + " side " + std::to_string(k) + " referenced " +
                    std::to_string(refs[i * 2 + size_t(k)]) + " times");
    }
  for (int32_t label : s.loose) {
    if (label < 0 || (m && (size_t(label) >= m->edge_count() || !m->is_double_edge[size_t(label)])))
      return fail("loose edge label is not a double edge");
  }
  auto holds = [&](const AABBd& b, const char* what) -> std::string {
    if (b.empty()) return {};
    for (const RawEdge& re : s.raw)
      for (const Vec3d& v : re.v)
        if (v.x < b.lo.x || v.y < b.lo.y || v.z < b.lo.z || v.x > b.hi.x || v.y > b.hi.y || v.z > b.hi.z)
          return fail(std::string("vertex outside the surface ") + what);
    return {};
  };
  if (!s.patches.empty() && s.hull.empty()) return fail("patches without a hull");
  if (std::string e = holds(s.box, "box"); !e.empty()) return e;
  if (std::string e = holds(s.hull, "hull"); !e.empty()) return e;
  return {};
}

}  // namespace visgate::iss
