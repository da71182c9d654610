// T-junction detection (see t_junctions.h).
#include "lib/repair/t_junctions.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "lib/mesh/box_tree.h"

namespace visgate::mesh {

namespace {

bool strictly_inside_segment(const Vec3d& a, const Vec3d& b, const Vec3d& p, const FilteredPredicates& fp) {
  if (p == a || p == b) return false;
  for (int ax = 0; ax < 3; ++ax)
    if (p[ax] < std::min(a[ax], b[ax]) || p[ax] > std::max(a[ax], b[ax])) return false;
  return fp.collinear(a, b, p);
}

}  // namespace

// Each boundary edge queries a tree of the boundary vertices with the segment itself:
// a node is visited only when its box overlaps the segment's box and the segment's line
// may meet it (line_may_meet_box, a conservative filter), so a long diagonal edge does
// not see every vertex inside its box.
std::vector<TJunction> find_t_junctions(const std::vector<Vec3d>& pos, const EdgeTable& e,
                                        const FilteredPredicates& fp) {
  std::vector<uint32_t> bedges;
  std::vector<uint32_t> bverts;
  for (uint32_t g = 0; g < e.groups(); ++g)
    if (e.size(g) == 1) {
      bedges.push_back(g);
      bverts.push_back(e.lo(g));
      bverts.push_back(e.hi(g));
    }
  std::vector<TJunction> out;
  if (bedges.empty()) return out;
  std::sort(bverts.begin(), bverts.end());
  bverts.erase(std::unique(bverts.begin(), bverts.end()), bverts.end());
  std::vector<Box3d> points(bverts.size());
  for (size_t i = 0; i < bverts.size(); ++i) points[i] = Box3d{pos[bverts[i]], pos[bverts[i]]};
  BoxTree tree(points);
  tbb::enumerable_thread_specific<std::vector<TJunction>> local;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, bedges.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<TJunction>& mine = local.local();
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const uint32_t g = bedges[i], lo = e.lo(g), hi = e.hi(g);
      const Vec3d &a = pos[lo], &b = pos[hi];
      const Box3d sb{vmin(a, b), vmax(a, b)};
      tree.query_if([&](const Box3d& x) { return boxes_overlap(x, sb) && line_may_meet_box(a, b, x.lo, x.hi); },
                    [&](uint32_t k) {
                      const uint32_t v = bverts[k];
                      if (v != lo && v != hi && strictly_inside_segment(a, b, pos[v], fp)) mine.push_back({v, g});
                    });
    }
  });
  for (auto& part : local) out.insert(out.end(), part.begin(), part.end());
  std::sort(out.begin(), out.end(), [](const TJunction& x, const TJunction& y) {
    return x.group != y.group ? x.group < y.group : x.v < y.v;
  });
  return out;
}

}  // namespace visgate::mesh
