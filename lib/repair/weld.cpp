// Welding by exact Euclidean distance (see weld_vertices_exact in repair.h).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "lib/base/union_find.h"
#include "lib/repair/repair.h"

namespace visgate::mesh {

namespace {

// Joins exactly equal positions (-0 == +0): neighbours in lexicographic order.
void join_equal_positions(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& ids, UnionFind& uf) {
  std::vector<uint32_t> order(ids);
  auto less = [&](uint32_t a, uint32_t b) {
    const Vec3d &p = pos[a], &q = pos[b];
    if (p.x != q.x) return p.x < q.x;
    if (p.y != q.y) return p.y < q.y;
    if (p.z != q.z) return p.z < q.z;
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  for (size_t i = 1; i < order.size(); ++i)
    if (pos[order[i]] == pos[order[i - 1]]) uf.unite(order[i], order[i - 1]);
}

// Joins every pair with |p - q| <= T (T > 0), found by spatial hashing. Cells of side
// h >= T (1 + 2^-8), at most 2^40 per axis so keys fit: two points within T then fall in
// the same or adjacent cells. The key floor(fl(fl(p - lo) / h)) is monotone in p, and its
// rounding error (a few ulps of a value below 2^41, i.e. below 2^-10) is smaller than the
// 2^-8 relative margin, so keys of points within T differ by at most one. The key is
// computed in long double (64-bit significand, wider exponent) so that p - lo cannot
// overflow.
void join_within_tolerance(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& ids, double tolerance,
                           const ExactPredicates& ex, UnionFind& uf) {
  Vec3d lo = pos[ids[0]], hi = lo;
  for (uint32_t i : ids) {
    lo = vmin(lo, pos[i]);
    hi = vmax(hi, pos[i]);
  }
  long double extent = 0;
  for (int k = 0; k < 3; ++k) extent = std::max(extent, (long double)hi[k] - (long double)lo[k]);
  const long double h = std::max((long double)tolerance, extent * 0x1p-40L) * (1.0L + 0x1p-8L);
  struct CellKey {
    int64_t c[3];
    uint32_t id;
  };
  std::vector<CellKey> keys(ids.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      keys[i].id = ids[i];
      for (int k = 0; k < 3; ++k)
        keys[i].c[k] = int64_t(std::floor(((long double)pos[ids[i]][k] - (long double)lo[k]) / h));
    }
  });
  // Cells as ranges of the keys sorted by cell.
  auto cell_less = [](const CellKey& x, const CellKey& y) {
    if (x.c[0] != y.c[0]) return x.c[0] < y.c[0];
    if (x.c[1] != y.c[1]) return x.c[1] < y.c[1];
    if (x.c[2] != y.c[2]) return x.c[2] < y.c[2];
    return x.id < y.id;
  };
  std::sort(keys.begin(), keys.end(), cell_less);
  auto cmp_cell = [](const int64_t* x, const int64_t* y) {
    for (int k = 0; k < 3; ++k)
      if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
    return 0;
  };
  std::vector<uint32_t> cell_start;
  for (uint32_t i = 0; i < keys.size(); ++i)
    if (i == 0 || cmp_cell(keys[i].c, keys[i - 1].c) != 0) cell_start.push_back(i);
  cell_start.push_back(uint32_t(keys.size()));
  const uint32_t ncells = uint32_t(cell_start.size() - 1);
  auto cell_key = [&](uint32_t cell) { return keys[cell_start[cell]].c; };
  const double t2 = tolerance * tolerance;
  auto try_pair = [&](uint32_t i, uint32_t j) {
    // Double filter: d2 and t2 carry relative errors below 8 * 2^-53; a 2^-40 margin
    // decides clear cases, the exact predicate the rest.
    Vec3d d = pos[i] - pos[j];
    double d2 = dot(d, d);
    if (d2 > t2 * (1 + 0x1p-40) && t2 > 0x1p-900) return;
    if ((d2 < t2 * (1 - 0x1p-40) && d2 > 0x1p-900) || ex.compare_distance(pos[i], pos[j], tolerance) <= 0)
      uf.unite(i, j);
  };
  auto cross_cells = [&](uint32_t a, uint32_t b) {
    for (uint32_t i = cell_start[a]; i < cell_start[a + 1]; ++i)
      for (uint32_t j = cell_start[b]; j < cell_start[b + 1]; ++j) try_pair(keys[i].id, keys[j].id);
  };
  // Each pair of adjacent cells once: a cell with itself, with (0, 0, +1), and with the
  // three cells z-1..z+1 of the rows (x, y+1), (x+1, y-1), (x+1, y), (x+1, y+1). Cells
  // are visited in sorted order, so the cells of each such row are found by a pointer
  // that only moves forward (a merge, no hashing).
  const int64_t rows[4][2] = {{0, 1}, {1, -1}, {1, 0}, {1, 1}};
  uint32_t ptr[4] = {0, 0, 0, 0};
  for (uint32_t cell = 0; cell < ncells; ++cell) {
    const int64_t* c = cell_key(cell);
    for (uint32_t i = cell_start[cell]; i < cell_start[cell + 1]; ++i)
      for (uint32_t j = i + 1; j < cell_start[cell + 1]; ++j) try_pair(keys[i].id, keys[j].id);
    if (cell + 1 < ncells) {
      const int64_t up[3] = {c[0], c[1], c[2] + 1};
      if (cmp_cell(cell_key(cell + 1), up) == 0) cross_cells(cell, cell + 1);
    }
    for (int r = 0; r < 4; ++r) {
      const int64_t first[3] = {c[0] + rows[r][0], c[1] + rows[r][1], c[2] - 1};
      const int64_t last[3] = {c[0] + rows[r][0], c[1] + rows[r][1], c[2] + 1};
      while (ptr[r] < ncells && cmp_cell(cell_key(ptr[r]), first) < 0) ++ptr[r];
      for (uint32_t o = ptr[r]; o < ncells && cmp_cell(cell_key(o), last) <= 0; ++o) cross_cells(cell, o);
    }
  }
}

// The cluster `list` (ascending, two or more members, rooted at list[0]) with its
// diameter: all pairs for clusters up to 4096 vertices; larger ones by a double sweep
// (farthest from the first, then farthest from that), a lower bound. Strict mode splits a
// cluster that exceeds T greedily; W.rep is set for every member.
void settle_cluster(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& list, double tolerance, WeldMode mode,
                    const ExactPredicates& ex, WeldResult& W) {
  WeldCluster wc;
  wc.vertices = list;
  auto farther = [&](uint32_t a, uint32_t b) {
    double d = length(pos[a] - pos[b]);
    wc.diameter = std::max(wc.diameter, d);
    if (!wc.exceeds_tolerance && d >= tolerance * (1 - 0x1p-40) && ex.compare_distance(pos[a], pos[b], tolerance) > 0)
      wc.exceeds_tolerance = true;
  };
  if (list.size() <= 4096) {
    for (size_t a = 0; a < list.size(); ++a)
      for (size_t b = a + 1; b < list.size(); ++b) farther(list[a], list[b]);
  } else {
    uint32_t far = list[0];
    double best = -1;
    for (uint32_t i : list) {
      double d = length(pos[i] - pos[list[0]]);
      if (d > best) { best = d; far = i; }
    }
    for (uint32_t i : list) farther(far, i);
  }
  if (!wc.exceeds_tolerance) return;
  if (mode == WeldMode::Strict) {
    // Greedy complete linkage in ascending index order: a vertex joins the first group
    // whose every member is within T of it.
    std::vector<std::vector<uint32_t>> groups;
    for (uint32_t i : list) {
      bool placed = false;
      for (auto& g : groups) {
        bool ok = true;
        for (uint32_t j : g)
          if (ex.compare_distance(pos[i], pos[j], tolerance) > 0) { ok = false; break; }
        if (ok) {
          g.push_back(i);
          placed = true;
          break;
        }
      }
      if (!placed) groups.push_back({i});
    }
    W.strict_splits += groups.size() - 1;
    for (auto& g : groups)
      for (uint32_t i : g) W.rep[i] = g[0];
  }
  W.chained.push_back(std::move(wc));
}

}  // namespace

WeldResult weld_vertices_exact(const std::vector<Vec3d>& pos, const std::vector<uint8_t>& used, double tolerance,
                               WeldMode mode, const ExactPredicates& ex) {
  const size_t n = pos.size();
  WeldResult W;
  W.rep.resize(n);
  std::iota(W.rep.begin(), W.rep.end(), 0u);
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < n; ++i)
    if (used[i]) ids.push_back(i);
  if (ids.empty()) return W;
  UnionFind uf(n);
  if (tolerance == 0.0) join_equal_positions(pos, ids, uf);
  else join_within_tolerance(pos, ids, tolerance, ex, uf);
  // Clusters (root = lowest member; members collected in ascending order).
  std::vector<uint32_t> size(n, 0);
  for (uint32_t i : ids) ++size[uf.find(i)];
  std::unordered_map<uint32_t, std::vector<uint32_t>> members;
  std::vector<uint32_t> roots;
  for (uint32_t i : ids) {
    uint32_t r = uf.find(i);
    if (size[r] < 2) continue;
    if (r == i) roots.push_back(r);
    members[r].push_back(i);
  }
  for (uint32_t r : roots) {
    const std::vector<uint32_t>& list = members[r];
    for (uint32_t i : list) W.rep[i] = r;
    if (tolerance != 0.0) settle_cluster(pos, list, tolerance, mode, ex, W);
  }
  std::fill(size.begin(), size.end(), 0u);
  for (uint32_t i : ids) {
    if (W.rep[i] != i) ++W.merged;
    if (++size[W.rep[i]] == 2) ++W.clusters;
  }
  return W;
}

}  // namespace visgate::mesh
