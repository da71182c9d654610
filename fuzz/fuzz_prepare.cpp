// fuzz_prepare: mesh preparation (lib/mesh/prepare.h, paper 000 section 4.2) on decoded
// blocker soups (lib/scene/byte_decoder.h; raw mode reaches shared and repeated vertices, -0/+0,
// duplicate and opposite-facing triangles, non-manifold edges). After prepare_mesh:
//   - mesh::validate() passes;
//   - no two vertex positions are equal and each is an input triangle corner;
//   - the triangles are exactly the input triangles without two equal corner positions,
//     in order, with the same corner positions (recomputed here from the soup);
//   - neighbours and labels match an independent recomputation from the soup: across an
//     edge used by exactly two triangles in opposite directions they are neighbours and
//     share one double-edge label; every other incidence has a single label of its own;
//   - the counts agree with what was found.
// Any violation prints it with the soup in hex-float and aborts.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "lib/scene/byte_decoder.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/scene_json.h"

namespace {

using namespace visgate;

[[noreturn]] void fail(const Scene& s, const std::string& what) {
  std::fprintf(stderr, "fuzz_prepare: %s\nscene (hex-float):\n%s", what.c_str(),
               write_scene_json(s, SceneWriteOptions{true}).c_str());
  std::abort();
}

// Position order with -0 == +0 (the weld's notion of equal).
bool pos_less(const Vec3f& a, const Vec3f& b) {
  return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::DecodeLimits lim;
  lim.max_triangles = 128;  // weld and neighbour search are near-linear; 128 stays sub-ms
  auto decoded = fuzz::decode_scene(data, size, lim);
  if (!decoded) return 0;
  const Scene& s = *decoded;
  const TriangleSoup& soup = s.mesh;

  mesh::PrepareCounts counts;
  mesh::PreparedMesh m = mesh::prepare_mesh(soup, &counts);

  std::string v = mesh::validate(m);
  if (!v.empty()) fail(s, "validate: " + v);

  // Unique, used vertices.
  std::vector<Vec3f> sorted = m.vertex_pos;
  std::sort(sorted.begin(), sorted.end(), pos_less);
  for (size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i] == sorted[i - 1]) fail(s, "two welded vertices have equal positions");
  for (const auto& t : m.triangles)
    for (uint32_t i : t.v)
      if (i >= m.vertex_pos.size()) fail(s, "vertex index out of range");
  // Every welded vertex is the position of some input triangle corner (vertices of
  // removed degenerate triangles may stay: the weld runs first, section 4.2).
  std::vector<Vec3f> corners;
  for (size_t t = 0; t < soup.size(); ++t)
    for (int k = 0; k < 3; ++k) corners.push_back(soup.corner(t, k));
  std::sort(corners.begin(), corners.end(), pos_less);
  for (const auto& p : m.vertex_pos)
    if (!std::binary_search(corners.begin(), corners.end(), p, pos_less)) fail(s, "a welded vertex is no input corner");

  // Triangles: the non-degenerate input triangles, in order, same corner positions.
  std::vector<uint32_t> kept;
  for (size_t t = 0; t < soup.size(); ++t) {
    Vec3f a = soup.corner(t, 0), b = soup.corner(t, 1), c = soup.corner(t, 2);
    if (!(a == b || b == c || c == a)) kept.push_back(uint32_t(t));
  }
  if (m.triangles.size() != kept.size())
    fail(s, "kept " + std::to_string(m.triangles.size()) + " triangles, expected " + std::to_string(kept.size()));
  for (size_t t = 0; t < kept.size(); ++t) {
    if (m.triangles[t].source != kept[t]) fail(s, "triangle " + std::to_string(t) + ": wrong source");
    for (int k = 0; k < 3; ++k)
      if (!(m.corner(t, k) == soup.corner(kept[t], k))) fail(s, "triangle " + std::to_string(t) + ": corner moved");
  }

  // Neighbours and labels, recomputed: incidences per undirected edge of welded indices
  // (positions are unique, so welded indices identify positions).
  struct Use { uint32_t tri; int k; bool forward; };
  std::map<std::pair<uint32_t, uint32_t>, std::vector<Use>> edges;
  for (uint32_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.triangles[t].v[k], b = m.triangles[t].v[(k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back({t, k, a < b});
    }
  size_t doubles = 0, singles = 0;
  std::vector<int> label_uses(m.edge_count(), 0);
  for (const auto& [key, uses] : edges) {
    const bool dbl = uses.size() == 2 && uses[0].forward != uses[1].forward;
    for (size_t u = 0; u < uses.size(); ++u) {
      const auto& tri = m.triangles[uses[u].tri];
      const int32_t expect = dbl ? int32_t(uses[1 - u].tri) : -1;
      if (tri.neighbors[uses[u].k] != expect)
        fail(s, "triangle " + std::to_string(uses[u].tri) + " edge " + std::to_string(uses[u].k) + ": neighbour " +
                    std::to_string(tri.neighbors[uses[u].k]) + ", expected " + std::to_string(expect));
      const uint32_t label = tri.edge_labels[uses[u].k];
      if (label >= m.edge_count()) fail(s, "edge label out of range");
      ++label_uses[label];
      if (bool(m.is_double_edge[label]) != dbl) fail(s, "double-edge flag wrong on label " + std::to_string(label));
    }
    if (dbl) {
      ++doubles;
      if (m.triangles[uses[0].tri].edge_labels[uses[0].k] != m.triangles[uses[1].tri].edge_labels[uses[1].k])
        fail(s, "neighbours across a double edge have different labels");
    } else {
      singles += uses.size();
    }
  }
  for (size_t l = 0; l < label_uses.size(); ++l)
    if (label_uses[l] != (m.is_double_edge[l] ? 2 : 1))
      fail(s, "label " + std::to_string(l) + " used " + std::to_string(label_uses[l]) + " times");

  // Counts.
  if (counts.input_triangles != soup.size() || counts.degenerate_removed != soup.size() - kept.size() ||
      counts.double_edges != doubles || counts.single_edges != singles ||
      counts.welded_vertices + m.vertex_pos.size() > counts.input_vertices)
    fail(s, "counts disagree with the recomputation");
  return 0;
}
