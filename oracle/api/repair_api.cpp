// The public API's mesh repair (include/visgate/visgate.h, target visgate::repair):
// lib/repair/repair.h with the exact CGAL predicates.
#include "lib/api/api_internal.h"
#include "lib/repair/repair.h"
#include "lib/repair/cgal_predicates.h"

namespace visgate::api {

Outcome<RepairedMesh> repair(const std::vector<double>& vertices, const std::vector<std::vector<uint32_t>>& faces,
                             const RepairSettings& settings) {
  using O = Outcome<RepairedMesh>;
  if (vertices.size() % 3 != 0) return O::failure("vertices: length is not a multiple of 3");
  PolygonSoup soup;
  for (size_t k = 0; k < vertices.size(); k += 3) soup.vertices.push_back(Vec3d(vertices[k], vertices[k + 1], vertices[k + 2]));
  soup.faces = faces;
  mesh::RepairOptions opt;
  opt.weld_tolerance = settings.weld_tolerance;
  opt.fill_holes = settings.fill_holes;
  mesh::CgalExactPredicates exact;
  auto r = mesh::repair_mesh(soup, opt, exact);
  if (!r) return O::failure(r.error().message);
  RepairedMesh out;
  for (const auto& v : r->output.vertices) out.vertices.insert(out.vertices.end(), {v.x, v.y, v.z});
  for (const auto& t : r->output.triangles) out.triangles.insert(out.triangles.end(), t.begin(), t.end());
  out.welded_vertices = r->weld.merged;
  out.removed_triangles = r->removed.size();
  out.defects_before = r->before.defects.total();
  out.defects_after = r->after.defects.total();
  return out;
}

}  // namespace visgate::api
