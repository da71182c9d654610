// The defect analysis of a mesh (see analyze_mesh in repair.h), phase by phase: faces,
// edges and components, closed shells (volume sign and nesting), boundary loops,
// T-junctions, vertex fans and genus, self-intersections.
#include <algorithm>
#include <chrono>

#include "lib/repair/mesh_topology.h"
#include "lib/repair/nesting.h"
#include "lib/repair/repair.h"
#include "lib/repair/self_intersection.h"
#include "lib/repair/t_junctions.h"

namespace visgate::mesh {

std::vector<std::pair<const char*, size_t>> DefectCounts::items() const {
  return {{"near_duplicate_vertices", near_duplicate_vertices},
          {"repeated_vertex_faces", repeated_vertex_faces},
          {"zero_area_faces", zero_area_faces},
          {"duplicate_faces", duplicate_faces},
          {"opposite_duplicate_faces", opposite_duplicate_faces},
          {"t_junctions", t_junctions},
          {"nonmanifold_edges", nonmanifold_edges},
          {"nonmanifold_vertices", nonmanifold_vertices},
          {"inconsistent_edges", inconsistent_edges},
          {"nonorientable_components", nonorientable_components},
          {"inward_components", inward_components},
          {"zero_volume_components", zero_volume_components},
          {"boundary_loops", boundary_loops},
          {"self_intersections", self_intersections}};
}

size_t DefectCounts::total() const {
  size_t s = 0;
  for (const auto& [name, n] : items()) s += n;
  return s;
}

namespace {

// What the phases share: the mesh, the faces that take part, the edge table and the
// components (faces joined through any shared edge).
struct MeshState {
  const std::vector<Vec3d>& pos;
  const std::vector<Tri>& tris;
  std::vector<uint8_t> active, candidate;  // not repeated-vertex / also not flat nor a copy
  EdgeTable e;
  std::vector<uint8_t> vert_on_nm_edge;
  std::vector<uint32_t> comp_of;          // triangle -> component, kNone for inactive ones
  std::vector<uint8_t> comp_nm, comp_bd;  // component has a non-manifold / boundary edge
  size_t nc = 0;
};

// Faces: repeated vertices, zero area, duplicates.
void analyze_faces(MeshState& s, const FilteredPredicates& fp, Analysis& A) {
  const size_t nt = s.tris.size();
  s.active.assign(nt, 1);
  s.candidate.assign(nt, 1);
  for (size_t t = 0; t < nt; ++t) {
    const Tri& f = s.tris[t];
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
      s.active[t] = s.candidate[t] = 0;
      ++A.defects.repeated_vertex_faces;
    } else if (fp.collinear(s.pos[f[0]], s.pos[f[1]], s.pos[f[2]])) {
      s.candidate[t] = 0;
      ++A.defects.zero_area_faces;
    }
  }
  std::vector<uint8_t> dup = find_duplicates(s.tris, s.active, s.pos.size());
  for (size_t t = 0; t < nt; ++t) {
    if (dup[t] == 1) ++A.defects.duplicate_faces;
    if (dup[t] == 2) ++A.defects.opposite_duplicate_faces;
    if (dup[t]) s.candidate[t] = 0;
  }
}

// Edges (boundary, non-manifold, inconsistent) and components with their face, edge and
// vertex counts.
void analyze_edges_and_components(MeshState& s, Analysis& A) {
  const size_t nt = s.tris.size();
  const EdgeTable& e = s.e = build_edges(s.tris, &s.active, s.pos.size());
  A.edges = e.groups();
  s.vert_on_nm_edge.assign(s.pos.size(), 0);
  for (size_t g = 0; g < e.groups(); ++g) {
    uint32_t n = e.size(g);
    if (n == 1) ++A.boundary_edges;
    if (n >= 3) {
      ++A.defects.nonmanifold_edges;
      A.nonmanifold_edges.push_back({e.lo(g), e.hi(g)});
      s.vert_on_nm_edge[e.lo(g)] = s.vert_on_nm_edge[e.hi(g)] = 1;
    }
    if (n == 2 && e.recs[e.start[g]].fwd == e.recs[e.start[g] + 1].fwd) ++A.defects.inconsistent_edges;
  }
  UnionFind comp_uf(nt);
  for (size_t g = 0; g < e.groups(); ++g)
    for (uint32_t i = e.start[g] + 1; i < e.start[g + 1]; ++i) comp_uf.unite(e.recs[e.start[g]].tri, e.recs[i].tri);
  s.comp_of.assign(nt, kNone);
  std::vector<uint32_t> roots;
  for (uint32_t t = 0; t < nt; ++t) {
    if (!s.active[t]) continue;
    uint32_t r = comp_uf.find(t);
    if (s.comp_of[r] == kNone) {
      s.comp_of[r] = uint32_t(roots.size());
      roots.push_back(r);
    }
    s.comp_of[t] = s.comp_of[r];
  }
  s.nc = roots.size();
  A.components.assign(s.nc, ComponentInfo{});
  s.comp_nm.assign(s.nc, 0);
  s.comp_bd.assign(s.nc, 0);
  for (uint32_t t = 0; t < nt; ++t)
    if (s.active[t]) ++A.components[s.comp_of[t]].faces;
  for (size_t g = 0; g < e.groups(); ++g) {
    uint32_t c = s.comp_of[e.recs[e.start[g]].tri];
    ++A.components[c].edges;
    if (e.size(g) >= 3) s.comp_nm[c] = 1;
    if (e.size(g) == 1) s.comp_bd[c] = 1;
    if (e.size(g) == 2 && e.recs[e.start[g]].fwd == e.recs[e.start[g] + 1].fwd) A.components[c].consistent = false;
  }
  // Distinct vertices per component: a vertex counts once for the first component that
  // uses it; the rare other (vertex, component) incidences (vertices shared by
  // components through a corner only) are sorted and counted apart.
  std::vector<uint32_t> first_comp(s.pos.size(), kNone);
  std::vector<uint64_t> extra;
  for (uint32_t t = 0; t < nt; ++t)
    if (s.active[t])
      for (uint32_t v : s.tris[t]) {
        if (first_comp[v] == kNone) {
          first_comp[v] = s.comp_of[t];
          ++A.components[s.comp_of[t]].vertices;
        } else if (first_comp[v] != s.comp_of[t]) {
          extra.push_back(uint64_t(s.comp_of[t]) << 32 | v);
        }
      }
  std::sort(extra.begin(), extra.end());
  extra.erase(std::unique(extra.begin(), extra.end()), extra.end());
  for (uint64_t x : extra) ++A.components[x >> 32].vertices;
}

// Orientability: parity propagation across two-face edges (BFS per component).
void analyze_orientability(const MeshState& s, Analysis& A) {
  const size_t nt = s.tris.size();
  const Adjacency adj = build_adjacency(s.e, nt);
  std::vector<int8_t> parity(nt, -1);
  std::vector<uint32_t> queue;
  for (uint32_t r = 0; r < nt; ++r) {
    if (!s.active[r] || parity[r] >= 0) continue;
    parity[r] = 0;
    queue.assign(1, r);
    for (size_t qi = 0; qi < queue.size(); ++qi) {
      uint32_t t = queue[qi];
      for (int k = 0; k < 3; ++k) {
        uint32_t u = adj.nb[3 * size_t(t) + size_t(k)];
        if (u == kNone) continue;
        int8_t want = int8_t(parity[t] ^ adj.same[3 * size_t(t) + size_t(k)]);
        if (parity[u] < 0) {
          parity[u] = want;
          queue.push_back(u);
        } else if (parity[u] != want) {
          A.components[s.comp_of[t]].orientable = false;
        }
      }
    }
  }
}

// Closed components: orientation by the exact sign of the enclosed volume; nesting: a
// shell inside an odd number of others bounds a cavity and faces inward.
void analyze_shells(const MeshState& s, const ExactPredicates& ex, const FilteredPredicates& fp, Analysis& A) {
  std::vector<std::vector<uint32_t>> members(s.nc);
  for (uint32_t t = 0; t < s.tris.size(); ++t)
    if (s.active[t] && !s.comp_nm[s.comp_of[t]] && !s.comp_bd[s.comp_of[t]]) members[s.comp_of[t]].push_back(t);
  for (size_t c = 0; c < s.nc; ++c) {
    ComponentInfo& ci = A.components[c];
    ci.closed = !s.comp_nm[c] && !s.comp_bd[c];
    if (ci.closed) ++A.closed_components;
    if (!ci.orientable) ++A.defects.nonorientable_components;
    if (ci.closed && ci.orientable && ci.consistent) {
      ci.volume_sign = ex.volume_sign(s.pos, s.tris, members[c]);
      if (ci.volume_sign == 0) ++A.defects.zero_volume_components;
    }
  }
  std::vector<std::vector<uint32_t>> shells;
  std::vector<size_t> shell_comp;
  for (size_t c = 0; c < s.nc; ++c)
    if (A.components[c].volume_sign != 0) {
      shells.push_back(std::move(members[c]));
      shell_comp.push_back(c);
    }
  const std::vector<int> depth = nesting_depths(s.pos, s.tris, shells, fp);
  for (size_t i = 0; i < shells.size(); ++i) {
    ComponentInfo& ci = A.components[shell_comp[i]];
    ci.depth = depth[i];
    if (depth[i] % 2 == 1) ++A.cavities;
    if (ci.volume_sign != (depth[i] % 2 == 1 ? -1 : 1)) ++A.defects.inward_components;
  }
}

// Non-manifold vertices (more than one fan), then the genus where it is defined.
void analyze_fans(const MeshState& s, Analysis& A) {
  const size_t nt = s.tris.size();
  UnionFind fans = corner_fans(s.tris, s.e);
  std::vector<uint32_t> first_root(s.pos.size(), kNone);
  std::vector<uint8_t> multi(s.pos.size(), 0);
  for (uint32_t t = 0; t < nt; ++t) {
    if (!s.active[t]) continue;
    for (uint32_t k = 0; k < 3; ++k) {
      uint32_t v = s.tris[t][k], r = fans.find(3 * t + k);
      if (first_root[v] == kNone) first_root[v] = r;
      else if (first_root[v] != r) multi[v] = 1;
    }
  }
  std::vector<uint8_t> comp_nmv(s.nc, 0);
  for (uint32_t v = 0; v < s.pos.size(); ++v)
    if (multi[v] && !s.vert_on_nm_edge[v]) A.nonmanifold_vertices.push_back(v);
  for (uint32_t t = 0; t < nt; ++t)
    if (s.active[t])
      for (uint32_t v : s.tris[t])
        if (multi[v]) comp_nmv[s.comp_of[t]] = 1;
  A.defects.nonmanifold_vertices = A.nonmanifold_vertices.size();
  // Genus where defined: orientable 2-manifold with boundary, chi = V - E + F = 2 - 2g - b.
  for (size_t c = 0; c < s.nc; ++c) {
    ComponentInfo& ci = A.components[c];
    if (!ci.orientable || s.comp_nm[c] || comp_nmv[c]) continue;
    long chi = long(ci.vertices) - long(ci.edges) + long(ci.faces);
    long twice_g = 2 - chi - long(ci.boundary_loops);
    if (twice_g >= 0 && twice_g % 2 == 0) ci.genus = int(twice_g / 2);
  }
}

}  // namespace

Analysis analyze_mesh(const IndexedMesh& m, const ExactPredicates& ex, const std::vector<uint32_t>* vertex_class) {
  Analysis A;
  const FilteredPredicates fp(ex);
  MeshState s{m.vertices, m.triangles, {}, {}, {}, {}, {}, {}, {}, 0};
  A.triangles = s.tris.size();
  {
    std::vector<uint8_t> seen(s.pos.size(), 0);
    for (const auto& t : s.tris)
      for (uint32_t v : t) seen[v] = 1;
    A.vertices = size_t(std::count(seen.begin(), seen.end(), uint8_t(1)));
  }
  auto phase = std::chrono::steady_clock::now();
  auto lap = [&](const char* what) {
    const auto now = std::chrono::steady_clock::now();
    A.seconds.push_back({what, std::chrono::duration<double>(now - phase).count()});
    phase = std::chrono::steady_clock::now();
  };
  analyze_faces(s, fp, A);
  lap("faces");
  analyze_edges_and_components(s, A);
  analyze_orientability(s, A);
  lap("components");
  analyze_shells(s, ex, fp, A);
  lap("volumes");
  for (Loop& L : boundary_loops(s.e)) {
    ++A.components[s.comp_of[s.e.recs[s.e.start[L.groups[0]]].tri]].boundary_loops;
    A.boundary_loops.push_back(std::move(L.verts));
  }
  A.defects.boundary_loops = A.boundary_loops.size();
  lap("boundary_loops");
  for (const TJunction& tj : find_t_junctions(s.pos, s.e, fp))
    A.t_junctions.push_back({tj.v, s.e.lo(tj.group), s.e.hi(tj.group)});
  A.defects.t_junctions = A.t_junctions.size();
  lap("t_junctions");
  analyze_fans(s, A);
  lap("fans");
  A.self_intersections = self_intersections(s.pos, s.tris, s.candidate, vertex_class ? vertex_class->data() : nullptr,
                                            fp, A.self_intersection_pairs_tested);
  A.defects.self_intersections = A.self_intersections.size();
  lap("self_intersections");
  return A;
}

}  // namespace visgate::mesh
