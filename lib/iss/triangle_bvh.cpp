// ISS's whole-mesh queries over the shared hierarchy (see triangle_bvh.h).
#include "lib/iss/triangle_bvh.h"

#include <algorithm>

namespace visgate::iss {

TriangleBvh::TriangleBvh(const std::vector<AABB>& triangle_boxes) : boxes_(triangle_boxes), bvh_(boxes_, kRule) {}

template <class Pred>
void TriangleBvh::collect(Pred&& visit, bool test_leaf_triangles, std::vector<uint32_t>& out) const {
  out.clear();
  bvh_.for_each_leaf(visit, [&](const accel::Bvh<float>::Node& leaf) {
    for (uint32_t t : bvh_.leaf_items(leaf))
      if (!test_leaf_triangles || visit(boxes_[t])) out.push_back(t);
  });
  std::sort(out.begin(), out.end());
}

void TriangleBvh::query_box(const AABB& box, std::vector<uint32_t>& out) const {
  collect([&](const AABB& b) { return b.overlaps(box); }, true, out);
}

void TriangleBvh::query_shaft(const ShaftGeometry& g, std::vector<uint32_t>& out) const {
  // The triangles of a visited leaf are returned untested: every consumer tests each
  // triangle against the shaft itself, so a second (box) test would only cost.
  collect([&](const AABB& b) { return g.may_intersect_box(to_double(b)); }, false, out);
}

size_t TriangleBvh::count_shaft(const ShaftGeometry& g, size_t limit) const {
  size_t n = 0;
  bvh_.for_each_leaf([&](const AABB& b) { return n < limit && g.may_intersect_box(to_double(b)); },
                     [&](const accel::Bvh<float>::Node& leaf) { n += bvh_.leaf_items(leaf).size(); });
  return n;
}

void TriangleBvh::query_shafts(const std::vector<ShaftGeometry>& gs, std::vector<uint32_t>& out) const {
  size_t last = 0;  // the shaft that admitted the previous node first: neighbours agree
  collect(
      [&](const AABB& b) {
        const AABBd bd = to_double(b);
        for (size_t i = 0; i < gs.size(); ++i) {
          const size_t k = (last + i) % gs.size();
          if (gs[k].may_intersect_box(bd)) {
            last = k;
            return true;
          }
        }
        return false;
      },
      true, out);
}

}  // namespace visgate::iss
