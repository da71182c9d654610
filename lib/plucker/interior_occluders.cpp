// Interior occluders of closed surfaces; see interior_occluders.h.
#include "lib/plucker/interior_occluders.h"

#include <algorithm>
#include <array>
#include <utility>
#include <cmath>
#include <numbers>

#include "lib/accel/bvh.h"
#include "lib/geom/predicates.h"
#include "lib/plucker/silhouette_region.h"

namespace visgate::plucker {

namespace {

// Exact sign of orient3d on float points: the filter first.
int o3(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  Sign s = orient3d_filtered(a, b, c, SumPoint(d));
  if (s == Sign::Uncertain) s = orient3d_exact(a, b, c, d);
  return s == Sign::Positive ? 1 : (s == Sign::Negative ? -1 : 0);
}

// The closed segment p -> q meets the closed triangle (a, b, c), or the test cannot tell
// (both ends in its plane, or a degenerate triangle): true. sp, sq: o3(a, b, c, p) and
// o3(a, b, c, q).
bool segment_meets_triangle(const Vec3f& p, const Vec3f& q, int sp, int sq, const Vec3f& a, const Vec3f& b,
                            const Vec3f& c) {
  if (sp * sq > 0) return false;
  if (sp == 0 && sq == 0) return true;
  // The line meets the plane at one point of the closed segment: inside the closed
  // triangle unless two edge lines see the line with strictly opposite signs.
  const int s1 = o3(p, q, a, b), s2 = o3(p, q, b, c), s3 = o3(p, q, c, a);
  const bool pos = s1 > 0 || s2 > 0 || s3 > 0, neg = s1 < 0 || s2 < 0 || s3 < 0;
  return !(pos && neg);
}

// The triangle's corners on one line (zero area: it adds nothing to a winding number):
// every coordinate projection's exact orientation zero.
bool collinear(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return orient2d_exact(a.x, a.y, b.x, b.y, c.x, c.y) == Sign::Zero &&
         orient2d_exact(a.y, a.z, b.y, b.z, c.y, c.z) == Sign::Zero &&
         orient2d_exact(a.z, a.x, b.z, b.x, c.z, c.x) == Sign::Zero;
}

struct Seg2 {
  double ax, ay, bx, by;
};

// Integer convex hull (Andrew), counter-clockwise, collinear points dropped.
std::vector<std::array<int64_t, 2>> hull(std::vector<std::array<int64_t, 2>> p) {
  std::sort(p.begin(), p.end());
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return {};
  auto cr = [](const std::array<int64_t, 2>& o, const std::array<int64_t, 2>& a, const std::array<int64_t, 2>& b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  };
  std::vector<std::array<int64_t, 2>> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cr(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cr(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h.size() >= 3 ? h : std::vector<std::array<int64_t, 2>>{};
}

// The planes per surface and light: offsets along the direction to the light (in box
// extents) and turns of the rays. One plane through the centre: measured on scan 75k,
// two more offset towards the receivers (-0.08, -0.16) and the rays turned by half a
// step on each covered 3% more candidates and took longer to build than they saved.
constexpr std::pair<double, double> kPlanes[] = {{0.0, 0.5}};
// The further polygons' planes (offsets as kPlanes) and the side of the grid of their
// centres (build_many).
// Measured on CGAL's bunny, armadillo and elephant (interior_extra 24): five planes with
// an 8 x 8 grid took the elephant from 12.5 to 7.0 user seconds (256 receivers), three
// planes to 9.9, 16 x 16 grids no better than 8 x 8.
constexpr double kExtraPlanes[] = {0.0, -0.15, 0.15, -0.3, 0.3};
constexpr int kGrid = 8;
// A further polygon's new cover (its area times the share of its probe points outside
// the polygons taken) at least this share of the largest candidate's area.
constexpr double kMinShare = 0.1;
constexpr double kCovered = 0.8;

// Every pass over a surface's triangles walks a hierarchy over their boxes (item i is
// tris[i]) and visits only the triangles in leaves whose box may matter: the set each
// pass computes (segments of the cross-section, a meeting triangle, the winding sum and
// whether a segment is clean) does not depend on the order, so the polygons are those of
// a scan over every triangle, found in time that follows the triangles near the plane,
// the polygon and the test segments (on scan: 3 passes per light over all of them were
// 5% of a 75k solve).
class Builder {
 public:
  Builder(const TriangleSoup& mesh, const std::vector<uint32_t>& tris, const accel::Bvh<float>& bvh, const AABB& box)
      : mesh_(mesh), tris_(tris), bvh_(bvh), box_(box) {}
  // The polygon facing direction `dir` in the plane `offset` times the box's extent from
  // its centre along dir, its corners on rays turned by `turn` of the angle between two
  // rays; or false.
  bool build(const Vec3d& dir, double offset, double turn, std::vector<Vec3f>& out);
  // Several polygons in the plane `offset` box extents from the centre along dir, each
  // inscribed along rays from its own centre (a grid over the box's cross-section, the
  // centres inside the approximate cross-section, largest first), for solids whose
  // cross-section is not star-shaped from one point (ears, limbs): a centre inside a
  // polygon already in `shadow` (the polygons' projections along dir, in the plane's u, v
  // coefficients) is skipped. Appends the verified polygons to out; true when the
  // plane's cross-section was covered already (nothing built).
  // Appends q's projection to shadow (build_many).
  void shadow_of(const Vec3d& dir, double offset, const std::vector<Vec3f>& q,
                 std::vector<std::vector<std::array<double, 2>>>& shadow);
  bool build_many(const Vec3d& dir, double offset, int grid, size_t max_polys,
                  std::vector<std::vector<std::array<double, 2>>>& shadow, std::vector<std::vector<Vec3f>>& out);

 private:
  struct Plane;
  bool plane_basis(const Vec3d& dir, double offset, Plane& pl) const;
  bool plane(const Vec3d& dir, double offset, Plane& pl);
  bool rays(const Plane& pl, double ci, double cj, double turn, std::array<double, InteriorOccluders::kMaxVertices>& hit,
            int* crossings) const;
  int ray_parity(const Plane& pl, double ci, double cj) const;
  bool polygon(const Plane& pl, int64_t ci, int64_t cj, double turn,
               const std::array<double, InteriorOccluders::kMaxVertices>& hit, std::vector<Vec3f>& out);
  bool verify(const std::vector<Vec3f>& q, const Vec3f& inner);
  bool inside(const Vec3f& x, std::span<const Vec3f> q);
  // f(t) for every triangle t of the surface in a leaf whose box, and every ancestor's,
  // passes enter(box).
  template <class Enter, class F>
  void each(Enter&& enter, F&& f) const {
    bvh_.for_each_leaf(enter, [&](const accel::Bvh<float>::Node& leaf) {
      for (uint32_t i : bvh_.leaf_items(leaf)) f(tris_[i]);
    });
  }
  const TriangleSoup& mesh_;
  const std::vector<uint32_t>& tris_;
  const accel::Bvh<float>& bvh_;
  const AABB& box_;
  std::vector<int8_t> side_;  // per vertex of the mesh: its side of Q's plane (verify)
};

// The plane's lattice and approximate cross-section (Builder::plane).
struct Builder::Plane {
  double h = 0;
  Vec3d p{}, u{}, v{}, nrm{}, du{}, dv{};
  std::vector<Seg2> segs;  // in (alpha, beta) coefficients of x - p in u, v
};

bool Builder::plane_basis(const Vec3d& dir, double offset, Plane& pl) const {
  const Vec3d lo = to_double(box_.lo), hi = to_double(box_.hi);
  const double ext = max_component(hi - lo);
  if (!(ext > 0.0) || !(length(dir) > 0.0)) return false;
  // The lattice: p, u, v multiples of h = 2^(e - 20) for ext in [2^e, 2^(e+1)); corners
  // p + i u + j v with |i|, |j| <= 2^10 are multiples of h below 2^24 h (checked: each is
  // a float) when the box is within 2^2 of its extent from the origin.
  const double h = std::ldexp(1.0, std::ilogb(ext) - 20);
  pl.h = h;
  auto grid = [&](const Vec3d& x) { return Vec3d(std::round(x.x / h) * h, std::round(x.y / h) * h, std::round(x.z / h) * h); };
  const Vec3d n = normalize(dir);
  const Vec3d p = grid((lo + hi) * 0.5 + n * (offset * ext));
  const Vec3d an = vabs(n);
  const Vec3d axis = an.x <= an.y && an.x <= an.z ? Vec3d(1, 0, 0) : (an.y <= an.z ? Vec3d(0, 1, 0) : Vec3d(0, 0, 1));
  const Vec3d u0 = normalize(cross(n, axis)), v0 = cross(n, u0);
  const double cell = ext / 512.0;
  const Vec3d u = grid(u0 * cell), v = grid(v0 * cell);
  const Vec3d nrm = cross(u, v);
  if (!(length(nrm) > 0.0)) return false;
  // Coefficients (alpha, beta) of x - p in the basis u, v (its plane part): dual vectors.
  const Vec3d du = cross(v, nrm) / dot(u, cross(v, nrm)), dv = cross(nrm, u) / dot(v, cross(nrm, u));
  pl.p = p, pl.u = u, pl.v = v, pl.nrm = nrm, pl.du = du, pl.dv = dv;
  return true;
}

bool Builder::plane(const Vec3d& dir, double offset, Plane& pl) {
  if (!plane_basis(dir, offset, pl)) return false;
  const Vec3d lo = to_double(box_.lo), hi = to_double(box_.hi);
  const double ext = max_component(hi - lo);
  const Vec3d p = pl.p, nrm = pl.nrm, du = pl.du, dv = pl.dv;
  // The cross-section, approximately (the checks below are exact).
  pl.segs.clear();
  // Boxes the plane may cross: the range of (x - p) . nrm over the box (its corners by
  // nrm's signs) reaches 0 within a margin far above the rounding of a vertex's value.
  const double margin = 0x1p-30 * (max_component(vabs(lo - p)) + max_component(vabs(hi - p)) + ext) *
                        (std::abs(nrm.x) + std::abs(nrm.y) + std::abs(nrm.z));
  auto straddles = [&](const AABB& bb) {
    const Vec3d bl = to_double(bb.lo) - p, bh = to_double(bb.hi) - p;
    const double smin =
        (nrm.x >= 0 ? bl.x : bh.x) * nrm.x + (nrm.y >= 0 ? bl.y : bh.y) * nrm.y + (nrm.z >= 0 ? bl.z : bh.z) * nrm.z;
    const double smax =
        (nrm.x >= 0 ? bh.x : bl.x) * nrm.x + (nrm.y >= 0 ? bh.y : bl.y) * nrm.y + (nrm.z >= 0 ? bh.z : bl.z) * nrm.z;
    return smin <= margin && smax >= -margin;
  };
  each(straddles, [&](uint32_t t) {
    Vec3d x[3];
    double s[3];
    for (int k = 0; k < 3; ++k) x[k] = to_double(mesh_.corner(t, k)) - p, s[k] = dot(x[k], nrm);
    Vec3d pts[2];
    int np = 0;
    for (int k = 0; k < 3 && np < 2; ++k) {
      const int k1 = (k + 1) % 3;
      if ((s[k] < 0.0) != (s[k1] < 0.0)) {
        const double t01 = s[k] / (s[k] - s[k1]);
        pts[np++] = x[k] + (x[k1] - x[k]) * t01;
      }
    }
    if (np == 2) pl.segs.push_back({dot(pts[0], du), dot(pts[0], dv), dot(pts[1], du), dot(pts[1], dv)});
  });
  return true;
}

// Nearest crossing of the approximate cross-section along kMaxVertices rays from the
// lattice point (ci, cj) (coefficients of the plane's p, u, v), turned by `turn` of a
// step; false when a ray meets nothing. `crossings` (optional): how many segments the
// first ray crosses, odd when the point is inside (approximately; only a choice).
bool Builder::rays(const Plane& pl, double ci, double cj, double turn, std::array<double, InteriorOccluders::kMaxVertices>& hit,
                   int* crossings) const {
  const int kRays = InteriorOccluders::kMaxVertices;
  for (int k = 0; k < kRays; ++k) {
    const double ang = 2.0 * std::numbers::pi * (double(k) + turn) / kRays;
    const double cx = std::cos(ang), cy = std::sin(ang);
    double best = std::numeric_limits<double>::infinity();
    int cross_count = 0;
    for (const Seg2& sg : pl.segs) {
      // c + t (cx, cy) = a + s (b - a), t > 0, s in [0, 1].
      const double ax = sg.ax - ci, ay = sg.ay - cj;
      const double ex = sg.bx - sg.ax, ey = sg.by - sg.ay;
      const double den = cx * ey - cy * ex;
      if (den == 0.0) continue;
      const double t = (ax * ey - ay * ex) / den, s = (ax * cy - ay * cx) / den;
      if (t > 0.0 && s >= 0.0 && s <= 1.0) best = std::min(best, t), ++cross_count;
    }
    if (!std::isfinite(best)) return false;
    hit[size_t(k)] = best;
    if (k == 0 && crossings) *crossings = cross_count;
  }
  return true;
}

// How many segments of the approximate cross-section the first ray of rays() from the
// lattice point (ci, cj) crosses (odd: inside, approximately; only a choice).
int Builder::ray_parity(const Plane& pl, double ci, double cj) const {
  int count = 0;
  for (const Seg2& sg : pl.segs) {
    const double ax = sg.ax - ci, ay = sg.ay - cj, ex = sg.bx - sg.ax, ey = sg.by - sg.ay;
    const double den = ey;  // the ray's direction is (1, 0)
    if (den == 0.0) continue;
    const double t = (ax * ey - ay * ex) / den, s = -ay / den;
    if (t > 0.0 && s >= 0.0 && s <= 1.0) ++count;
  }
  return count;
}

// The convex polygon through the points at `shrink` of the hits, in lattice coordinates
// from the centre (ci, cj) (integers), when the centre is strictly inside it, every
// corner is a float, and verify() passes.
bool Builder::polygon(const Plane& pl, int64_t ci, int64_t cj, double turn,
                      const std::array<double, InteriorOccluders::kMaxVertices>& hit, std::vector<Vec3f>& out) {
  const int kRays = InteriorOccluders::kMaxVertices;
  const Vec3d centre = pl.p + pl.u * double(ci) + pl.v * double(cj);
  for (double shrink : {0.97, 0.85, 0.7}) {
    std::vector<std::array<int64_t, 2>> pts;
    for (int k = 0; k < kRays; ++k) {
      const double ang = 2.0 * std::numbers::pi * (double(k) + turn) / kRays;
      const double r = std::min(shrink * hit[size_t(k)], 1000.0);
      pts.push_back({int64_t(std::trunc(r * std::cos(ang))), int64_t(std::trunc(r * std::sin(ang)))});
    }
    const auto hl = hull(pts);
    if (hl.empty()) return false;
    // The centre (0, 0) strictly inside the hull: the inner point of the winding test.
    bool strict = true;
    for (size_t k = 0; k < hl.size(); ++k) {
      const auto &a = hl[k], &b = hl[(k + 1) % hl.size()];
      strict &= a[0] * b[1] - a[1] * b[0] > 0;
    }
    if (!strict) continue;
    std::vector<Vec3f> q;
    bool exact = true;
    for (const auto& ij : hl) {
      const Vec3d x = centre + pl.u * double(ij[0]) + pl.v * double(ij[1]);
      const Vec3f xf(x);
      exact &= to_double(xf).x == x.x && to_double(xf).y == x.y && to_double(xf).z == x.z;
      q.push_back(xf);
    }
    const Vec3f pf(centre);
    exact &= to_double(pf).x == centre.x && to_double(pf).y == centre.y && to_double(pf).z == centre.z;
    if (!exact) return false;
    if (verify(q, pf)) {
      out = std::move(q);
      return true;
    }
  }
  return false;
}

bool Builder::build(const Vec3d& dir, double offset, double turn, std::vector<Vec3f>& out) {
  Plane pl;
  if (!plane(dir, offset, pl)) return false;
  std::array<double, InteriorOccluders::kMaxVertices> hit{};
  if (!rays(pl, 0.0, 0.0, turn, hit, nullptr)) return false;
  return polygon(pl, 0, 0, turn, hit, out);
}

namespace {
// Point strictly inside a convex polygon (counter-clockwise or clockwise), doubles.
bool inside_convex(const std::vector<std::array<double, 2>>& poly, double x, double y) {
  int pos = 0, neg = 0;
  for (size_t k = 0; k < poly.size(); ++k) {
    const auto &a = poly[k], &b = poly[(k + 1) % poly.size()];
    const double c = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    pos += c > 0.0, neg += c < 0.0;
  }
  return pos == int(poly.size()) || neg == int(poly.size());
}
}  // namespace

void Builder::shadow_of(const Vec3d& dir, double offset, const std::vector<Vec3f>& q,
                        std::vector<std::vector<std::array<double, 2>>>& shadow) {
  Plane pl;
  if (!plane_basis(dir, offset, pl)) return;
  std::vector<std::array<double, 2>>& sh = shadow.emplace_back();
  for (const Vec3f& x : q) sh.push_back({dot(to_double(x), pl.du), dot(to_double(x), pl.dv)});
}

bool Builder::build_many(const Vec3d& dir, double offset, int grid, size_t max_polys,
                         std::vector<std::vector<std::array<double, 2>>>& shadow, std::vector<std::vector<Vec3f>>& out) {
  Plane pl;
  if (!plane(dir, offset, pl) || pl.segs.empty()) return false;
  // The lattice coordinates of the box's corners bound the grid of centres.
  const Vec3d lo = to_double(box_.lo), hi = to_double(box_.hi);
  double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
  for (int c = 0; c < 8; ++c) {
    const Vec3d x = Vec3d(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z) - pl.p;
    const double a = dot(x, pl.du), b = dot(x, pl.dv);
    amin = std::min(amin, a), amax = std::max(amax, a), bmin = std::min(bmin, b), bmax = std::max(bmax, b);
  }
  struct Cand {
    double area;
    int64_t ci, cj;
    std::array<double, InteriorOccluders::kMaxVertices> hit;
  };
  std::vector<Cand> cands;
  const int kRays = InteriorOccluders::kMaxVertices;
  // Shadow coordinates: (alpha, beta) of x itself (u, v and the duals are the same in
  // every plane of one direction, so the projections along dir compare across planes).
  const double pa = dot(pl.p, pl.du), pb = dot(pl.p, pl.dv);
  auto centre = [&](int gi, int gj) {
    return std::pair<int64_t, int64_t>(int64_t(std::round(amin + (amax - amin) * (gi + 0.5) / grid)),
                                       int64_t(std::round(bmin + (bmax - bmin) * (gj + 0.5) / grid)));
  };
  // A cross-section the polygons taken already cover (at least kCovered of the grid
  // points inside it, by the parity of one ray): further polygons there would be slivers
  // at its boundary (scan's ellipsoid: 86-100% in every plane; the bunny, armadillo and
  // elephant: 0-79%). One ray per point before the ten of a candidate.
  {
    size_t inside = 0, in_shadow = 0;
    for (int gi = 0; gi < grid; ++gi)
      for (int gj = 0; gj < grid; ++gj) {
        const auto [ci, cj] = centre(gi, gj);
        if (ray_parity(pl, double(ci), double(cj)) % 2 == 0) continue;
        ++inside;
        bool seen = false;
        for (const auto& sh : shadow) seen = seen || inside_convex(sh, pa + double(ci), pb + double(cj));
        in_shadow += seen;
      }
    if (double(in_shadow) >= kCovered * double(inside)) return true;
  }
  for (int gi = 0; gi < grid; ++gi)
    for (int gj = 0; gj < grid; ++gj) {
      const auto [ci, cj] = centre(gi, gj);
      Cand c{0.0, ci, cj, {}};
      int crossings = 0;
      if (!rays(pl, double(ci), double(cj), 0.0, c.hit, &crossings) || crossings % 2 == 0) continue;
      for (int k = 0; k < kRays; ++k)
        c.area += 0.5 * std::min(c.hit[size_t(k)], 1000.0) * std::min(c.hit[size_t((k + 1) % kRays)], 1000.0) *
                  std::sin(2.0 * std::numbers::pi / kRays);
      cands.push_back(c);
    }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) { return a.area > b.area; });
  std::vector<Vec3f> q;
  for (const Cand& c : cands) {
    if (out.size() >= max_polys) break;
    // New cover: at least half of points spread over the candidate (its centre, and
    // each ray at 0.3 and 0.8 of its hit) outside every polygon taken.
    int fresh = 0, all = 0;
    auto probe = [&](double x, double y) {
      bool seen = false;
      for (const auto& sh : shadow) seen = seen || inside_convex(sh, pa + x, pb + y);
      fresh += !seen, ++all;
    };
    probe(double(c.ci), double(c.cj));
    for (int k = 0; k < kRays; ++k) {
      const double ang = 2.0 * std::numbers::pi * double(k) / kRays, r = std::min(c.hit[size_t(k)], 1000.0);
      for (double f : {0.3, 0.8}) probe(double(c.ci) + f * r * std::cos(ang), double(c.cj) + f * r * std::sin(ang));
    }
    // ... and its fresh part (area times that share) at least kMinShare of the largest
    // candidate's area: slivers between a polygon and a convex cross-section's boundary
    // cost a tree occluder and a covered test per candidate and cover little.
    if (2 * fresh < all || c.area * double(fresh) < kMinShare * cands[0].area * double(all)) continue;
    if (!polygon(pl, c.ci, c.cj, 0.0, c.hit, q)) continue;
    std::vector<std::array<double, 2>>& sh = shadow.emplace_back();
    for (const Vec3f& x : q) sh.push_back({dot(to_double(x), pl.du), dot(to_double(x), pl.dv)});
    out.push_back(q);
  }
  return false;
}

bool Builder::verify(const std::vector<Vec3f>& q, const Vec3f& inner) {
  side_.assign(mesh_.vertices.size(), 2);  // 2: not yet decided
  AABB qb;
  for (const Vec3f& x : q) qb.extend(x);
  bool meets = false;
  // A node whose box lies strictly on one side of Q's plane (its eight float corners, exact
  // signs; the half-space is convex) holds only triangles the side test below skips.
  const auto straddles = [&](const AABB& bb) {
    const int s0 = o3(q[0], q[1], q[2], bb.lo);
    if (s0 == 0) return true;
    for (int k = 1; k < 8; ++k) {
      const Vec3f x(k & 1 ? bb.hi.x : bb.lo.x, k & 2 ? bb.hi.y : bb.lo.y, k & 4 ? bb.hi.z : bb.lo.z);
      if (o3(q[0], q[1], q[2], x) != s0) return true;
    }
    return false;
  };
  each([&](const AABB& bb) { return !meets && bb.overlaps(qb) && straddles(bb); }, [&](uint32_t t) {
    if (meets) return;
    const Vec3f &a = mesh_.corner(t, 0), &b = mesh_.corner(t, 1), &c = mesh_.corner(t, 2);
    AABB tb;
    tb.extend(a), tb.extend(b), tb.extend(c);
    if (!tb.overlaps(qb)) return;
    // Strictly on one side of Q's plane (exact, once per vertex): apart.
    auto side = [&](int k) {
      int8_t& sd = side_[mesh_.triangles[t][size_t(k)]];
      if (sd == 2) sd = int8_t(o3(q[0], q[1], q[2], mesh_.corner(t, k)));
      return int(sd);
    };
    const int sides[3] = {side(0), side(1), side(2)};
    if (sides[0] != 0 && sides[0] == sides[1] && sides[0] == sides[2]) return;
    meets = polygon_meets_triangle(q, a, b, c, sides);
  });
  return !meets && inside(inner, q);
}

// The closed segment x -> f misses the closed float box bb, by exact signs: for some
// axis, the box's projection along it lies strictly on one side of the segment's
// projected line (orient2d is linear in the point, so its least and greatest values
// over the rectangle are at the corners chosen by the signs of the line's direction).
// False may also mean "cannot tell" (a projected segment of zero length).
// Not segment_meets_box negated (triangle_tree.cpp): that one rounds in double with a 2^-40 margin, all six axes.
bool segment_misses_box(const Vec3f& x, const Vec3f& f, const AABB& bb) {
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    const float xi = x[i], xj = x[j], fi = f[i], fj = f[j];
    // orient2d(x, f, c) = (fi - xi)(cj - xj) - (fj - xj)(ci - xi): increasing in cj when
    // fi > xi, in ci when fj < xj.
    const float lo_i = fj < xj ? bb.lo[i] : bb.hi[i], lo_j = fi > xi ? bb.lo[j] : bb.hi[j];
    if (orient2d_exact(xi, xj, fi, fj, lo_i, lo_j) == Sign::Positive) return true;
    const float hi_i = fj < xj ? bb.hi[i] : bb.lo[i], hi_j = fi > xi ? bb.hi[j] : bb.lo[j];
    if (orient2d_exact(xi, xj, fi, fj, hi_i, hi_j) == Sign::Negative) return true;
  }
  return false;
}

// Winding number of the surface at x nonzero: signed proper crossings of a segment from
// x to a float point beyond the box; a segment through an edge or a vertex of a triangle,
// or lying in a triangle's plane, is not used (the next direction is tried).
// Nodes whose box the segment misses (segment_misses_box) are not entered: their
// triangles neither cross nor touch it, so they add nothing to the count nor to
// cleanness, whatever their planes. (x is on no triangle, Q meeting none, so w(x) is
// the count along any clean direction: leaving such triangles out can only turn a
// direction that a far triangle in the segment's plane made unclean into a clean one
// giving the same w.)
bool Builder::inside(const Vec3f& x, std::span<const Vec3f> /*q*/) {
  const double ext = max_component(to_double(box_.hi) - to_double(box_.lo));
  // Directions off the axes and off simple ratios (a mesh's vertices often lie on rays
  // from its centre along the axes).
  static constexpr double kDirs[6][3] = {{1.0, 0.3719, 0.1537},  {-0.2913, 1.0, 0.4471}, {0.3307, -0.1759, 1.0},
                                         {-1.0, -0.4127, 0.2671}, {0.1913, -1.0, -0.3583}, {-0.4219, 0.2357, -1.0}};
  for (const auto& dv : kDirs) {
    // At least 2 extents along the dominant axis from a point of the box: beyond it.
    const Vec3f f(to_double(x) + Vec3d(dv[0], dv[1], dv[2]) * (2.0 * ext));
    AABB sb;
    sb.extend(x), sb.extend(f);
    int w = 0;
    bool clean = true;
    each([&](const AABB& bb) { return clean && bb.overlaps(sb) && !segment_misses_box(x, f, bb); }, [&](uint32_t t) {
      if (!clean) return;
      const Vec3f &a = mesh_.corner(t, 0), &b = mesh_.corner(t, 1), &c = mesh_.corner(t, 2);
      AABB tb;
      tb.extend(a), tb.extend(b), tb.extend(c);
      if (!tb.overlaps(sb)) return;
      const int sx = o3(a, b, c, x), sf = o3(a, b, c, f);
      if (sx * sf >= 0) {
        // Not strictly across the plane: no proper crossing. x on the plane but off the
        // triangle (Q meets none) or f beyond the box: the segment touches it nowhere
        // inside, unless the whole segment lies in the plane of a triangle of nonzero area.
        if (sx == 0 && sf == 0 && !collinear(a, b, c)) clean = false;
        return;
      }
      const int s1 = o3(x, f, a, b), s2 = o3(x, f, b, c), s3 = o3(x, f, c, a);
      if (s1 != 0 && s1 == s2 && s2 == s3) {
        w += sx > 0 ? 1 : -1;
      } else {
        const bool pos = s1 > 0 || s2 > 0 || s3 > 0, neg = s1 < 0 || s2 < 0 || s3 < 0;
        if (!(pos && neg)) clean = false;  // through an edge or a vertex
      }
    });
    if (clean) return w != 0;
  }
  return false;
}

}  // namespace

bool polygon_meets_triangle(std::span<const Vec3f> q, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const int sides[3] = {o3(q[0], q[1], q[2], a), o3(q[0], q[1], q[2], b), o3(q[0], q[1], q[2], c)};
  return polygon_meets_triangle(q, a, b, c, sides);
}

bool polygon_meets_triangle(std::span<const Vec3f> q, const Vec3f& a, const Vec3f& b, const Vec3f& c,
                            const int sides[3]) {
  // Two convex polygons meet iff an edge of one meets the other (the ends of their
  // common segment lie on their boundaries).
  // An edge p -> p' of the triangle: apart when strictly on one side of Q's plane; in the
  // plane, undecided (meets). Else its line crosses the plane at one point x of the
  // closed edge, and orient3d(p, p', u, v) for u, v in the plane is orient2d(x, u, v)
  // times the sign of (p' - p) . n: x lies in the closed Q iff Q's edges (u, v) do not
  // see the line with strictly opposite signs (their orient2d sum twice Q's area, so
  // outside Q one is positive and one negative).
  const size_t n = q.size();
  const Vec3f t[3] = {a, b, c};
  for (int e = 0; e < 3; ++e) {
    const int sp = sides[e], sq = sides[(e + 1) % 3];
    if (sp * sq > 0) continue;
    if (sp == 0 && sq == 0) return true;
    const Vec3f &p = t[e], &p1 = t[(e + 1) % 3];
    bool pos = false, neg = false;
    for (size_t k = 0; k < n && !(pos && neg); ++k) {
      const int s = o3(p, p1, q[k], q[(k + 1) % n]);
      pos |= s > 0, neg |= s < 0;
    }
    if (!(pos && neg)) return true;
  }
  // Q's edges against the triangle, each corner's side of the triangle's plane computed
  // once.
  const int s0 = o3(a, b, c, q[0]);
  int sk = s0;
  for (size_t k = 0; k < n; ++k) {
    const int sk1 = k + 1 < n ? o3(a, b, c, q[k + 1]) : s0;
    if (segment_meets_triangle(q[k], q[(k + 1) % n], sk, sk1, a, b, c)) return true;
    sk = sk1;
  }
  return false;
}

InteriorOccluders::InteriorOccluders(const Scene& scene, const ClosedSurfaces& cs, size_t extra,
                                     const SurfaceTrees* trees) {
  // Per surface large enough, its triangles and triangle_hierarchy over them (Builder):
  // trees' when given.
  std::vector<std::vector<uint32_t>> own_tris;
  std::vector<accel::Bvh<float>> own_bvhs;
  if (!trees) {
    own_tris = cs.triangle_lists();
    own_bvhs.resize(cs.count());
    for (size_t s = 0; s < cs.count(); ++s)
      if (own_tris[s].size() >= kMinTriangles) own_bvhs[s] = triangle_hierarchy(scene.mesh, own_tris[s]);
  }
  const auto tris_of = [&](size_t s) -> const std::vector<uint32_t>& {
    return trees ? trees->triangles(int32_t(s)) : own_tris[s];
  };
  const auto bvh_of = [&](size_t s) -> const accel::Bvh<float>& {
    return trees ? trees->hierarchy(int32_t(s)) : own_bvhs[s];
  };
  light_begin_.push_back(0);
  std::vector<Vec3f> q;
  for (uint32_t li = 0; li < scene.lights.size(); ++li) {
    Vec3d lc(0, 0, 0);
    for (const Vec3f& v : scene.lights[li].polygon) lc = lc + to_double(v);
    lc = lc / double(scene.lights[li].polygon.size());
    for (size_t s = 0; s < cs.count(); ++s) {
      if (tris_of(s).size() < kMinTriangles) continue;
      const AABB& box = cs.box(int32_t(s));
      Builder b(scene.mesh, tris_of(s), bvh_of(s), box);
      const Vec3d dir = lc - (to_double(box.lo) + to_double(box.hi)) * 0.5;
      std::vector<std::vector<std::array<double, 2>>> shadow;
      std::vector<std::vector<Vec3f>> more;
      for (const auto& [offset, turn] : kPlanes) {
        if (!b.build(dir, offset, turn, q)) continue;
        entries_.push_back({int32_t(s), li, uint32_t(poly_.size()), uint32_t(q.size())});
        poly_.insert(poly_.end(), q.begin(), q.end());
        if (extra > 0) b.shadow_of(dir, offset, q, shadow);
      }
      // Further polygons where the cross-sections leave the first one's projection
      // (kExtraPlanes; build_many): non-convex solids.
      // A central plane already covered (scan's ellipsoid): no further plane either.
      for (double offset : kExtraPlanes) {
        if (more.size() >= extra) break;
        if (b.build_many(dir, offset, kGrid, extra, shadow, more) && offset == kExtraPlanes[0]) break;
      }
      for (const std::vector<Vec3f>& m : more) {
        entries_.push_back({int32_t(s), li, uint32_t(poly_.size()), uint32_t(m.size())});
        poly_.insert(poly_.end(), m.begin(), m.end());
      }
    }
    light_begin_.push_back(entries_.size());
  }
}

}  // namespace visgate::plucker
