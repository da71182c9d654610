// lib/iss/leaf_rays.cpp: the queued leaf rays (ray_queue) give every relation the answer
// the unqueued leaf caster gives, and both agree with the double reference; the direct
// test (direct_rays) answers like the Embree leaf rays and the exact oracle.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/iss/traversal.h"
#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

// Every relation's bit, light-major, as the solver wrote it.
std::vector<bool> bits(const Scene& s, const SolveResult& r) {
  std::vector<bool> out;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < s.relation_count() / s.receivers.size(); ++k) out.push_back(r.receivers[i].visible(k));
  return out;
}

}  // namespace

TEST(IssLeafRays, QueuedPacketsAnswerLikeTheUnqueuedCaster) {
  // Light leaves of 2 to 4 samples leave packets an eighth to a quarter full
  // unless the rays are queued; the queue must not change which relations are rays
  // nor any answer.
  for (const std::string fam : {"columns", "random-soup", "torus"}) {
    FamilyParams fp;
    fp.seed = 3;
    fp.receivers = 144;
    fp.samples = 16;
    if (fam == "columns") fp.triangles = 1000;
    auto gen = generate_family(fam, fp);
    ASSERT_TRUE(gen.ok()) << fam;
    const Scene& s = gen.value();
    for (const char* leaf : {"2", "3", "4"}) {
      std::map<std::string, std::string> o = {
          {"leaf_samples", leaf}, {"leaf_receivers", "8"}, {"auto_rays", "off"}, {"direct_rays", "off"}};
      SolveResult queued = run_iss(s, o);
      o["ray_queue"] = "off";
      SolveResult direct = run_iss(s, o);
      EXPECT_GT(queued.stats.get("relations_ray_cast"), 0.0) << fam << " leaf " << leaf;
      EXPECT_EQ(queued.stats.get("relations_ray_cast"), direct.stats.get("relations_ray_cast")) << fam << " leaf " << leaf;
      EXPECT_EQ(queued.stats.get("rays_blocked"), direct.stats.get("rays_blocked")) << fam << " leaf " << leaf;
      EXPECT_TRUE(bits(s, queued) == bits(s, direct)) << fam << " leaf " << leaf;
      Compare c = compare_to_reference(s, queued);
      EXPECT_EQ(c.mismatches, 0u) << fam << " leaf " << leaf;
      EXPECT_GT(c.checked, s.relation_count() / 2) << fam << " leaf " << leaf;
    }
  }
}

namespace {

// Relations of non-degenerate class whose answer in `r` differs from the exact oracle's,
// over all margins and over those of margin at least tau.
struct Wrong {
  size_t any = 0, above_tau = 0, checked = 0;
};
Wrong wrong_against_oracle(const Scene& s, const oracle::RelationOracleResult& ex, const SolveResult& r, double tau) {
  Wrong w;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < ex.classes[i].size(); ++k) {
      const char cls = ex.classes[i][k];
      if (cls == 'd') continue;
      const bool bad = r.receivers[i].visible(k) != (cls == 'v');
      w.any += bad;
      if (ex.margins[i][k] >= tau) {
        ++w.checked;
        w.above_tau += bad;
      }
    }
  return w;
}

// A leaf path that only adds certified answers (`on`) against the answers without it
// (`off`): no answer wrong above tau, no more wrong answers at any margin, and every
// relation where the two differ answered as the exact oracle answers (a certified answer
// is exact; an Embree ray can be wrong only within its float rounding of an edge, and a
// degenerate relation has no single answer).
void expect_exact_where_they_differ(const Scene& s, const SolveResult& on, const SolveResult& off, double tau,
                                    const std::string& what) {
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
  const Wrong w_on = wrong_against_oracle(s, ex, on, tau), w_off = wrong_against_oracle(s, ex, off, tau);
  EXPECT_GT(w_on.checked, s.relation_count() / 4) << what;
  EXPECT_EQ(w_on.above_tau, 0u) << what;
  EXPECT_LE(w_on.any, w_off.any) << what;
  size_t differ_wrong = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < ex.classes[i].size(); ++k) {
      const char cls = ex.classes[i][k];
      if (cls != 'd' && on.receivers[i].visible(k) != off.receivers[i].visible(k))
        differ_wrong += on.receivers[i].visible(k) != (cls == 'v');
    }
  EXPECT_EQ(differ_wrong, 0u) << what;
}

// An option that changes only how leaf relations are decided (`on` with it, `off`
// without): the same shafts, `stat` zero without it, every relation decided once (by a
// shaft, a cell or a leaf test) and no more rays.
void expect_same_shafts_no_more_rays(const Scene& s, const SolveResult& on, const SolveResult& off, const char* stat,
                                     const std::string& what) {
  EXPECT_EQ(on.stats.get("shafts_built"), off.stats.get("shafts_built")) << what;
  EXPECT_EQ(off.stats.get(stat), 0.0) << what;
  EXPECT_EQ(on.stats.get("relations_blocked_by_shaft") + on.stats.get("relations_visible_by_empty_shaft") +
                on.stats.get("relations_ray_cast"),
            double(s.relation_count()))
      << what;
  EXPECT_LE(on.stats.get("relations_ray_cast"), off.stats.get("relations_ray_cast")) << what;
}

struct LeafCase {
  const char* fam;
  long tris, recv, samples;
  std::map<std::string, std::string> opts;
};

// Each case solved with `option` on (its options as given) and off: the checks of
// expect_same_shafts_no_more_rays (`off_stat` zero without it) and
// expect_exact_where_they_differ; on rooms `stat` above zero. Returns `stat` summed.
double expect_option_cases(const std::vector<LeafCase>& cases, const char* option, const char* off_stat,
                           const char* stat) {
  double total = 0;
  for (const LeafCase& c : cases) {
    Scene s = family(c.fam, 5, c.tris, c.recv, c.samples);
    EXPECT_FALSE(s.receivers.empty()) << c.fam;
    if (s.receivers.empty()) continue;
    std::map<std::string, std::string> o = c.opts;
    SolveResult on = run_iss(s, o);
    o[option] = "off";
    SolveResult off = run_iss(s, o);
    const std::string what = std::string(c.fam) + " " + describe(c.opts);
    expect_same_shafts_no_more_rays(s, on, off, off_stat, what);
    total += on.stats.get(stat);
    if (std::string(c.fam) == "rooms") {
      EXPECT_GT(on.stats.get(stat), 0.0) << what;
    }
    expect_exact_where_they_differ(s, on, off, 1e-5, what);
  }
  return total;
}

}  // namespace

TEST(IssLeafRays, DirectTestAnswersLikeEmbreeRaysAndTheOracle) {
  // The direct test decides the leaf relations it can certify and leaves the rest to
  // the Embree rays: the same relations are cast as with direct_rays=off, and where the
  // two differ the direct answer is the exact one (a certified answer is exact; the
  // Embree ray can be wrong only within its float rounding of a triangle edge).
  const double tau = 1e-5;
  const LeafCase cases[] = {
      // Light splits (64-receiver x 4-sample leaves): tests grouped by light point.
      {"columns", 2500, 4096, 64, {}},
      // Whole-light leaves of 8 receivers x 64 samples: tests grouped by receiver.
      {"columns", 1000, 1024, 64, {{"light_split", "off"}, {"leaf_receivers", "8"}, {"auto_rays", "off"}}},
      // Leaves of up to 1024 receivers x 64 samples: more relations than one chunk of
      // the test's scratch arrays (Traversal::kDirectChunk).
      {"columns", 200, 4096, 64, {{"light_split", "off"}, {"leaf_receivers", "1024"}, {"auto_rays", "off"}}},
      {"random-soup", -1, 256, 16, {{"leaf_receivers", "8"}, {"auto_rays", "off"}}},
      {"torus", -1, 256, 16, {{"leaf_receivers", "8"}, {"auto_rays", "off"}}},
      {"on-surface", -1, 256, 16, {{"leaf_receivers", "8"}, {"auto_rays", "off"}}},
      {"shared-edge-fan", -1, 256, 16, {{"leaf_receivers", "8"}, {"auto_rays", "off"}}},
      {"grid-snapped", -1, 256, 16, {{"leaf_receivers", "8"}, {"auto_rays", "off"}}},
  };
  double direct_total = 0, uncertified_total = 0;
  for (const LeafCase& c : cases) {
    Scene s = family(c.fam, 5, c.tris, c.recv, c.samples);
    ASSERT_FALSE(s.receivers.empty()) << c.fam;
    std::map<std::string, std::string> o = c.opts;
    o["cell_shafts"] = "off";  // cells decide some leaf relations without a test (tested below)
    SolveResult on = run_iss(s, o);
    o["direct_rays"] = "off";
    SolveResult off = run_iss(s, o);
    EXPECT_EQ(on.stats.get("relations_ray_cast"), off.stats.get("relations_ray_cast")) << c.fam;
    EXPECT_EQ(off.stats.get("direct_ray_relations"), 0.0) << c.fam;
    direct_total += on.stats.get("direct_ray_relations");
    uncertified_total += on.stats.get("direct_rays_uncertified");
    if (std::string(c.fam) == "columns") {
      EXPECT_GT(on.stats.get("direct_ray_relations"), 0.0) << describe(c.opts);
    }
    expect_exact_where_they_differ(s, on, off, tau, std::string(c.fam) + " " + describe(c.opts));
  }
  EXPECT_GT(direct_total, 0.0);
  // Some relations of these scenes lie on a triangle's plane or edge and cannot be certified.
  EXPECT_GT(uncertified_total, 0.0);
}

TEST(IssLeafRays, CellShaftsAnswerAsWithoutThemAndTheOracle) {
  // Cell shafts (cell_shafts) decide whole light cells of a leaf receiver by certified
  // predicates at the cell's corners; they change how a leaf is decided, never which
  // shafts are built. Every answer they give is the exact one, so it differs from the
  // leaf answers without them only where those (Embree rays) were wrong. Both the
  // default (the light node's box only) and the full descent to the light-tree leaves.
  const std::map<std::string, std::string> deep = {{"cell_depth", "16"}, {"cell_candidates", "1024"}};
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {}},
      {"rooms", -1, 256, 64, deep},
      // Columns: the light trial keeps some lights whole at these sizes (with
      // light_split=off the whole light is a light-tree leaf: no cells below it).
      {"columns", 1000, 1024, 64, {}},
      {"columns", 1000, 1024, 64, deep},
      {"random-soup", -1, 256, 16, deep},
      {"torus", -1, 256, 16, deep},
      {"on-surface", -1, 256, 16, deep},
      {"shared-edge-fan", -1, 256, 16, deep},
      {"grid-snapped", -1, 256, 16, deep},
  };
  EXPECT_GT(expect_option_cases(cases, "cell_shafts", "cell_shafts", "cell_shaft_relations"), 0.0);
}

TEST(IssLeafRays, CellPatchesAnswerAsWithoutThemAndTheOracle) {
  // Planar patches (cell_patches) block a cell that their coplanar triangles cover
  // together (a box face's two triangles, a tessellated plane). They change only how a
  // cell is decided: the same shafts, every relation once, no more rays, and every
  // answer where on and off differ the exact one.
  const std::map<std::string, std::string> deep = {{"cell_depth", "16"}, {"cell_candidates", "1024"}};
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {}},
      {"rooms", -1, 256, 64, deep},
      {"columns", 1000, 1024, 64, deep},
      {"double-surface", -1, 256, 16, deep},
      {"shared-edge-fan", -1, 256, 16, deep},
      {"grid-snapped", -1, 256, 16, deep},
      {"random-soup", -1, 256, 16, deep},
  };
  expect_option_cases(cases, "cell_patches", "cell_patch_relations", "cell_patch_relations");
}

TEST(IssLeafRays, CellPatchesCoverOnlyWhereTheirTrianglesDo) {
  // Hand-made: a light above a tessellated square (a 9 x 9 grid of quads, two coplanar
  // triangles each) over a grid of receivers. Whole: every relation blocked (by the
  // shafts' merged surfaces). With one quad left out (a hole) and with one quad's second triangle folded
  // onto the first (neighbours across the diagonal on one side: no cover beyond it),
  // the patches must not block what the hole or the fold lets through: every relation
  // as the exact oracle answers it, and as without patches.
  for (int variant = 0; variant < 3; ++variant) {
    Scene s;
    s.name = "patch-cover";
    const int n = 9;
    const double h = 2.0 / n;
    for (int b = 0; b < n; ++b)
      for (int a = 0; a < n; ++a) {
        if (variant == 1 && a == 4 && b == 4) continue;  // the hole
        const Vec3d p00(-1 + a * h, -1 + b * h, 1), p10 = p00 + Vec3d(h, 0, 0), p11 = p00 + Vec3d(h, h, 0),
                    p01 = p00 + Vec3d(0, h, 0);
        if (variant == 2 && a == 4 && b == 4) {
          // Triangle (p00, p10, p11) and its neighbour across p00 p11 folded back onto
          // its side: (p11, p00, p10 + (0, h / 2, 0)), opposite traversal, same plane.
          shapes::add_quad(s.mesh, p00, p10, p11, p10 + Vec3d(0, h / 2, 0));
          continue;
        }
        shapes::add_quad(s.mesh, p00, p10, p11, p01);
      }
    s.lights.push_back(make_square_light_down(Vec3d(0, 0, 2), 0.15, 64, 7));
    for (int b = 0; b < 16; ++b)
      for (int a = 0; a < 16; ++a) {
        Receiver r;
        r.p = Vec3f(Vec3d(-0.6 + 1.2 * a / 15, -0.6 + 1.2 * b / 15, 0));
        s.receivers.push_back(r);
      }
    ASSERT_TRUE(finish_scene(s).ok());
    std::map<std::string, std::string> o = {{"cell_depth", "16"}, {"cell_candidates", "1024"}};
    SolveResult on = run_iss(s, o);
    o["cell_patches"] = "off";
    SolveResult off = run_iss(s, o);
    const std::string what = "variant " + std::to_string(variant);
    expect_same_shafts_no_more_rays(s, on, off, "cell_patch_relations", what);
    if (variant == 0) {
      EXPECT_EQ(count_visible(s, on), 0.0) << what;
    } else {  // the hole's neighbourhood is left to the cells (the shafts see it)
      EXPECT_GT(count_visible(s, on), 0.0) << what;
      EXPECT_GT(on.stats.get("cell_patch_relations"), 0.0) << what;
    }
    expect_exact_where_they_differ(s, on, off, 1e-5, what);
    for (size_t i = 0; i < s.receivers.size(); ++i)
      for (size_t k = 0; k < s.relation_count() / s.receivers.size(); ++k)
        EXPECT_EQ(on.receivers[i].visible(k), off.receivers[i].visible(k)) << what << " receiver " << i;
  }
}

TEST(IssLeafRays, CellBackfacesAnswerAsWithoutThemAndTheOracle) {
  // Dropping the faces of closed star-shaped surfaces turned strictly away from a
  // receiver node (cell_backfaces) lets leaves with too many candidates take cells. It
  // changes only how a leaf is decided: the same shafts, every relation once, no more
  // rays, and every answer where on and off differ the exact one. A small
  // cell_candidates makes the scenes' closed surfaces (rooms' spheres, the torus, which
  // is not star-shaped) exceed it.
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {{"cell_candidates", "64"}}},
      {"rooms", -1, 256, 64, {{"cell_candidates", "64"}, {"cell_depth", "16"}}},
      {"columns", 1000, 1024, 64, {{"cell_candidates", "8"}}},
      {"torus", -1, 256, 16, {{"cell_candidates", "8"}, {"cell_depth", "16"}}},
      {"random-soup", -1, 256, 16, {{"cell_candidates", "8"}}},
      {"shared-edge-fan", -1, 256, 16, {{"cell_candidates", "8"}}},
  };
  expect_option_cases(cases, "cell_backfaces", "cell_backface_relations", "cell_backface_relations");
}

TEST(IssLeafRays, CellGroupsAnswerAsWithoutThemAndTheOracle) {
  // A cell left mixed takes cells at groups of its samples (cell_groups) before the
  // direct test. It changes only how a cell's relations are decided: the same shafts,
  // every relation once, no more rays, and every answer where on and off differ the
  // exact one. Small groups and halves down to one sample (cell_group_min 1) on every
  // mixed cell, a group size that does not divide the light's samples, and groups below
  // cells of cell_depth reach the other paths.
  const std::map<std::string, std::string> small = {
      {"cell_group_samples", "4"}, {"cell_group_min", "1"}, {"cell_group_candidates", "1024"}, {"cell_candidates", "64"}};
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {}},
      {"rooms", -1, 256, 64, small},
      {"rooms", -1, 256, 64, {{"cell_group_samples", "5"}, {"cell_depth", "1"}}},
      {"rooms", 60000, 256, 64, {{"cell_group_samples", "8"}, {"cell_group_min", "2"}}},
      {"columns", 1000, 1024, 64, {{"light_split", "off"}, {"cell_group_samples", "8"}, {"cell_group_min", "1"}}},
      {"torus", -1, 256, 16, small},
      {"random-soup", -1, 256, 16, small},
      {"shared-edge-fan", -1, 256, 16, small},
      {"on-surface", -1, 256, 16, small},
      {"grid-snapped", -1, 256, 16, small},
  };
  expect_option_cases(cases, "cell_groups", "cell_group_relations", "cell_group_relations");
}

TEST(IssLeafRays, CellSurfacesAnswerAsWithoutThemAndTheOracle) {
  // A leaf still over cell_candidates after cell_backfaces takes cells receiver by
  // receiver where the closed surfaces whose box lies outside the pyramid from the
  // receiver over the light's box are left out (cell_surfaces). The same checks as for
  // cell_backfaces: the same shafts, every relation once, no more rays, and every answer
  // where on and off differ the exact one. Small cell_candidates make the scenes' closed
  // surfaces exceed it after the node-box cull.
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {{"cell_candidates", "64"}}},
      {"rooms", -1, 256, 64, {{"cell_candidates", "32"}, {"cell_surface_candidates", "32"}, {"cell_depth", "16"}}},
      {"rooms", 60000, 256, 64, {{"cell_candidates", "96"}, {"cell_surface_candidates", "192"}}},
      {"columns", 1000, 1024, 64, {{"cell_candidates", "8"}}},
      {"torus", -1, 256, 16, {{"cell_candidates", "8"}, {"cell_depth", "16"}}},
      {"random-soup", -1, 256, 16, {{"cell_candidates", "8"}}},
      {"shared-edge-fan", -1, 256, 16, {{"cell_candidates", "8"}}},
  };
  expect_option_cases(cases, "cell_surfaces", "cell_surface_relations", "cell_surface_relations");
}

namespace {

int sgn(Sign s) { return s == Sign::Positive ? 1 : s == Sign::Negative ? -1 : 0; }

// Exact: the open segment (p, q) crosses the open triangle at one point strictly inside
// it (every edge orientation of one strict sign, p and q strictly on opposite sides).
bool crosses_strictly(const Vec3f& p, const Vec3f& q, const Vec3f* t) {
  const int a = sgn(orient3d_exact(p, q, t[0], t[1])), b = sgn(orient3d_exact(p, q, t[1], t[2])),
            c = sgn(orient3d_exact(p, q, t[2], t[0]));
  const int sp = sgn(orient3d_exact(t[0], t[1], t[2], p)), sq = sgn(orient3d_exact(t[0], t[1], t[2], q));
  return a != 0 && a == b && b == c && sp != 0 && sp == -sq;
}

// Exact, conservative: the closed segment may meet the closed triangle (false only when
// p and q lie strictly on one side of its plane, or the line passes strictly beside
// one of its edges, two edge orientations strictly opposite).
bool may_meet(const Vec3f& p, const Vec3f& q, const Vec3f* t) {
  const int sp = sgn(orient3d_exact(t[0], t[1], t[2], p)), sq = sgn(orient3d_exact(t[0], t[1], t[2], q));
  if (sp != 0 && sp == sq) return false;
  const int a = sgn(orient3d_exact(p, q, t[0], t[1])), b = sgn(orient3d_exact(p, q, t[1], t[2])),
            c = sgn(orient3d_exact(p, q, t[2], t[0]));
  return !(std::max({a, b, c}) > 0 && std::min({a, b, c}) < 0);
}

}  // namespace

TEST(IssLeafRays, CellCentreCertificateHoldsOverTheWholeBox) {
  // The cells' certificate from the box's centre and half extents (cell_centre,
  // cell_group_centre: w(c) +- h.|grad w| and its rounding bound) against the exact
  // orientations at the box's corners, its centre and random points of it: a block must
  // cross strictly at every one, a miss meet none. Random triangles, origins and boxes
  // (some flat, some tiny, some on a coarse grid so that segments graze edges and
  // planes exactly, some single points: a vertex, or within rounding of an edge's plane
  // through p).
  // It decides what the corners' certificate decides (the same exact
  // range of each affine w) up to the rounding bounds' difference.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0), ext(0.0, 0.4);
  std::uniform_int_distribution<int> grid(-8, 8), pick(0, 3);
  size_t decided[2] = {0, 0}, corner_decided[2] = {0, 0}, only_corners[2] = {0, 0}, blocks = 0, misses = 0, wrong = 0;
  for (int it = 0; it < 20000; ++it) {
    const bool snap = pick(rng) == 0;
    auto coord = [&](double scale) { return float(snap ? grid(rng) / 8.0 * scale : u(rng) * scale); };
    Vec3f tri[3];
    for (auto& v : tri) v = Vec3f(coord(1.0), coord(1.0), coord(1.0));
    const Vec3f p(coord(2.0), coord(2.0), coord(2.0));
    AABB box;
    Vec3f c(coord(2.0), coord(2.0), coord(2.0));
    const int flat = pick(rng);  // 0..2: that axis flat, 3: none
    const double tiny = pick(rng) == 0 ? 1e-3 : 1.0;
    // One box in four a single point: a vertex of the triangle (two w exactly 0, computed
    // with rounding: only the rounding bounds keep them undecided) or a point next to
    // the plane through p and an edge (within the float rounding of a point of it).
    const bool point = !snap && pick(rng) == 0;
    if (point && pick(rng) < 2) {
      c = tri[pick(rng) % 3];
    } else if (point) {
      const Vec3d A(tri[0]), B(tri[1]), P(p);
      const double lam = u(rng), mu = u(rng);
      c = Vec3f(A + (B - A) * lam + (A - P) * mu);
    }
    for (int a = 0; a < 3; ++a) {
      const double h = point || a == flat ? 0.0 : (snap ? 1.0 / 8.0 : ext(rng) * tiny);
      box.lo[a] = float(c[a] - h);
      box.hi[a] = float(c[a] + h);
    }
    std::vector<Vec3f> qs;
    for (int k = 0; k < 8; ++k)
      qs.emplace_back(k & 1 ? box.hi.x : box.lo.x, k & 2 ? box.hi.y : box.lo.y, k & 4 ? box.hi.z : box.lo.z);
    qs.push_back(c);
    std::uniform_real_distribution<double> in(0.0, 1.0);
    for (int k = 0; k < 16; ++k) {
      Vec3f q;
      for (int a = 0; a < 3; ++a) q[a] = std::clamp(float(box.lo[a] + in(rng) * (box.hi[a] - box.lo[a])), box.lo[a], box.hi[a]);
      qs.push_back(q);
    }
    for (int side = 0; side < 2; ++side) {
      const int r = iss::cell_certificate(tri, p, box, true, side == 1);
      const int rc = iss::cell_certificate(tri, p, box, false, side == 1);
      decided[side] += r != 0;
      corner_decided[side] += rc != 0;
      only_corners[side] += rc != 0 && r == 0;
      EXPECT_FALSE(r != 0 && rc != 0 && r != rc) << "it " << it;  // both exact: never opposite
      if (r == 0) continue;
      (r == 1 ? blocks : misses) += 1;
      for (const Vec3f& q : qs) {
        if (q == p) continue;
        const bool bad = r == 1 ? !crosses_strictly(p, q, tri) : may_meet(p, q, tri);
        wrong += bad;
        EXPECT_FALSE(bad) << "it " << it << " side " << side << " certified " << (r == 1 ? "blocked" : "missed");
        if (bad) break;
      }
    }
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(blocks, 200u);
  EXPECT_GT(misses, 2000u);
  for (int side = 0; side < 2; ++side) {
    EXPECT_GT(decided[side], 0u);
    // At most 1% of the corners' decisions left undecided by the centre.
    EXPECT_LE(100 * only_corners[side], corner_decided[side]) << "side " << side;
  }
}

TEST(IssLeafRays, CellCacheAnswersAsWithoutItAndTheOracle) {
  // The cached vector (cell_cache) blocks a receiver's node cell by the node cells' own
  // certificate over the light node's box, before the leaf's candidates are read: the
  // same shafts, every relation once, no more rays, on rooms some cells decided by it,
  // and every answer where on and off differ the exact one. With the corners
  // (cell_centre=off) the cache takes the corner certificate.
  const std::map<std::string, std::string> deep = {{"cell_depth", "16"}, {"cell_candidates", "1024"}};
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {}},
      {"rooms", -1, 256, 64, {{"cell_centre", "off"}, {"cell_group_centre", "off"}}},
      {"rooms", -1, 256, 64, deep},
      {"columns", 1000, 1024, 64, {{"light_split", "off"}}},
      {"torus", -1, 256, 16, deep},
      {"random-soup", -1, 256, 16, deep},
      {"shared-edge-fan", -1, 256, 16, deep},
      {"grid-snapped", -1, 256, 16, deep},
  };
  EXPECT_GT(expect_option_cases(cases, "cell_cache", "cell_cache_relations", "cell_cache_relations"), 0.0);
}

TEST(IssLeafRays, CellCentreAnswersAsCornersAndTheOracle) {
  // cell_centre and cell_group_centre change only the arithmetic of the cells'
  // certificates: the same shafts, every relation decided once, about as many rays as
  // the corners' (the same exact ranges, other rounding bounds), and every answer where
  // they differ the exact one.
  const std::vector<LeafCase> cases = {
      {"rooms", -1, 256, 64, {}},
      {"rooms", -1, 256, 64, {{"cell_depth", "16"}, {"cell_candidates", "1024"}}},
      {"columns", 1000, 1024, 64, {{"light_split", "off"}, {"cell_group_samples", "8"}, {"cell_group_min", "1"}}},
      {"torus", -1, 256, 16, {{"cell_depth", "16"}}},
      {"random-soup", -1, 256, 16, {{"cell_depth", "16"}}},
      {"shared-edge-fan", -1, 256, 16, {{"cell_depth", "16"}}},
      {"grid-snapped", -1, 256, 16, {{"cell_depth", "16"}, {"cell_group_samples", "4"}, {"cell_group_min", "1"}}},
  };
  for (const LeafCase& c : cases) {
    Scene s = family(c.fam, 5, c.tris, c.recv, c.samples);
    ASSERT_FALSE(s.receivers.empty()) << c.fam;
    std::map<std::string, std::string> o = c.opts;
    SolveResult on = run_iss(s, o);
    o["cell_centre"] = "off";
    o["cell_group_centre"] = "off";
    SolveResult off = run_iss(s, o);
    const std::string what = std::string(c.fam) + " " + describe(c.opts);
    EXPECT_EQ(on.stats.get("shafts_built"), off.stats.get("shafts_built")) << what;
    EXPECT_EQ(on.stats.get("relations_blocked_by_shaft") + on.stats.get("relations_visible_by_empty_shaft") +
                  on.stats.get("relations_ray_cast"),
              double(s.relation_count()))
        << what;
    EXPECT_LE(on.stats.get("relations_ray_cast"), off.stats.get("relations_ray_cast") * 1.01 + 16) << what;
    if (std::string(c.fam) == "rooms") {
      EXPECT_GT(on.stats.get("cell_shaft_relations"), 0.0) << what;
    }
    expect_exact_where_they_differ(s, on, off, 1e-5, what);
  }
}
