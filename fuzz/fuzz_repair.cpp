// fuzz_repair: `visgate repair` as a property. The input decodes to a small
// polygon soup on a quarter-unit grid, where coplanar, collinear, coincident and
// T-junction configurations are common, and to options (weld tolerance 0 or one grid
// step, hole filling off or on). Checked:
//   - idempotence: repairing the repaired mesh writes the same OBJ bytes;
//   - honesty: the analysis of the output (`repair --check` of the written file) equals
//     the report's "after" counts;
//   - hole filling never adds a self-intersection, duplicate or opposite-duplicate face,
//     or non-manifold edge.
// On a failure the soup is printed (vertices in hex-float, faces) and the run aborts.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <tbb/global_control.h>

#include "lib/repair/repair.h"
#include "lib/repair/cgal_predicates.h"

namespace {

using namespace visgate;
using namespace visgate::mesh;

[[noreturn]] void fail(const std::string& what, const PolygonSoup& s, const RepairOptions& o) {
  std::fprintf(stderr, "fuzz_repair: %s\noptions: weld_tolerance %a fill_holes %zu\n", what.c_str(), o.weld_tolerance,
               o.fill_holes);
  for (const Vec3d& v : s.vertices) std::fprintf(stderr, "v %a %a %a\n", v.x, v.y, v.z);
  for (const auto& f : s.faces) {
    std::fprintf(stderr, "f");
    for (uint32_t i : f) std::fprintf(stderr, " %u", i + 1);
    std::fprintf(stderr, "\n");
  }
  std::abort();
}

PolygonSoup as_soup(const IndexedMesh& m) {
  PolygonSoup s;
  s.vertices = m.vertices;
  for (const auto& t : m.triangles) s.faces.push_back({t[0], t[1], t[2]});
  s.double_precision = m.double_precision;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  // One thread: the soups are tiny, and fuzz builds compile CGAL without thread safety.
  static const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  static const mesh::CgalExactPredicates ex;
  RepairOptions o;
  o.weld_tolerance = data[0] & 1 ? 0.25 : 0.0;
  o.fill_holes = data[0] & 2 ? 64 : 0;
  // Vertices: a count, then three signed bytes each, in quarter units.
  const size_t nv = 3 + data[1] % 30;
  size_t at = 2;
  PolygonSoup s;
  for (size_t i = 0; i < nv && at + 3 <= size; ++i, at += 3)
    s.vertices.push_back(Vec3d(int8_t(data[at]) / 4.0, int8_t(data[at + 1]) / 4.0, int8_t(data[at + 2]) / 4.0));
  if (s.vertices.size() < 3) return 0;
  // Faces: a byte k gives 3 + k % 4 corners (k >= 252: the previous face listed 2 to 5
  // times over, up to 64 corners), then one byte per corner.
  while (at < size && s.faces.size() < 200) {
    const uint8_t k = data[at++];
    if (k >= 252 && !s.faces.empty()) {
      const std::vector<uint32_t>& prev = s.faces.back();
      std::vector<uint32_t> f;
      for (int r = 0; r < 2 + k % 4 && f.size() + prev.size() <= 64; ++r) f.insert(f.end(), prev.begin(), prev.end());
      s.faces.push_back(std::move(f));
      continue;
    }
    std::vector<uint32_t> f;
    for (size_t c = 0; c < 3u + k % 4 && at < size; ++c) f.push_back(uint32_t(data[at++] % s.vertices.size()));
    s.faces.push_back(std::move(f));
  }
  auto r1 = repair_mesh(s, o, ex);
  if (!r1) return 0;  // no faces
  if (r1->output.triangles.empty()) return 0;
  auto b1 = encode_mesh(r1->output, MeshFormat::Obj, "fuzz.obj");
  if (!b1) fail("encode failed: " + b1.error().message, s, o);
  const PolygonSoup back = as_soup(r1->output);
  auto r2 = repair_mesh(back, o, ex);
  if (!r2) fail("repair of the output failed: " + r2.error().message, s, o);
  auto b2 = encode_mesh(r2->output, MeshFormat::Obj, "fuzz.obj");
  if (!b2 || *b1 != *b2) fail("not idempotent: repair(repair(x)) != repair(x)", s, o);
  RepairOptions check = o;
  check.check_only = true;
  check.fill_holes = 0;
  auto c = repair_mesh(back, check, ex);
  if (!c) fail("check of the output failed", s, o);
  const auto after = r1->after.defects.items(), checked = c->before.defects.items();
  for (size_t i = 0; i < after.size(); ++i)
    if (after[i].second != checked[i].second)
      fail(std::string("--check of the output disagrees on ") + after[i].first + ": report " +
               std::to_string(after[i].second) + ", check " + std::to_string(checked[i].second),
           s, o);
  if (o.fill_holes > 0) {
    // Fills are checked against the mesh as it was: no defect of these kinds may grow.
    RepairOptions plain = o;
    plain.fill_holes = 0;
    auto r0 = repair_mesh(s, plain, ex);
    if (!r0) fail("repair without filling failed", s, o);
    const DefectCounts &a = r0->after.defects, &b = r1->after.defects;
    if (b.self_intersections > a.self_intersections || b.duplicate_faces > a.duplicate_faces ||
        b.opposite_duplicate_faces > a.opposite_duplicate_faces || b.nonmanifold_edges > a.nonmanifold_edges)
      fail("hole filling added a self-intersection, duplicate or non-manifold edge", s, o);
  }
  return 0;
}
