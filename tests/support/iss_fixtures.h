// Test fixtures of the ISS tests (tests/iss/): the solver under each option set, an
// independent double-precision reference, and small helpers. validate() runs after
// every operation in every test that includes this header (set_validate_all).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "lib/iss/blockers.h"
#include "lib/iss/iss_solver.h"
#include "lib/solver.h"
#include "oracle/relation_oracle.h"
#include "tests/support/scenes.h"

namespace visgate::test_support {

// validate() after every operation in every ISS test (set_validate_all).
struct ValidateOn : ::testing::Environment {
  void SetUp() override { iss::set_validate_all(true); }
};
inline const auto* const kValidateOn = ::testing::AddGlobalTestEnvironment(new ValidateOn);

// The option sets every hand-worked scene runs under.
inline const std::vector<std::map<std::string, std::string>> kOptionSets = {
    {},
    {{"ray_caster", "custom"}},
    {{"postpone", "off"}, {"leaf_receivers", "4"}, {"leaf_samples", "1"}, {"auto_rays", "off"}},
    {{"ray_caster", "custom"}, {"postpone", "off"}, {"leaf_receivers", "64"}, {"leaf_samples", "16"}},
};

inline SolveResult run_iss(const Scene& s, const std::map<std::string, std::string>& o) {
  iss::IssSolver solver;
  SolveOptions so;
  so.opts = o;
  so.threads = 1;
  EXPECT_TRUE(solver.check_options(so).ok());
  return solver.solve(s, so);
}

// Against the exact relation oracle: the relations it decides with margin at least tau
// (`checked`), how many answers of `rs` are wrong there (`wrong`), how many of those
// relations the first two of `rs` answer differently (`differ`), and how many relations
// not touching (any margin) they answer differently (`differ_any`).
struct OracleTally {
  size_t checked = 0, wrong = 0, differ = 0, differ_any = 0;
};
inline OracleTally tally_against_oracle(const Scene& s, const oracle::RelationOracleResult& ex, double tau,
                                        std::initializer_list<const SolveResult*> rs) {
  OracleTally t;
  const SolveResult* first = *rs.begin();
  const SolveResult* second = rs.size() > 1 ? *(rs.begin() + 1) : first;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < ex.classes[i].size(); ++k) {
      const char cls = ex.classes[i][k];
      if (cls == 'd') continue;  // touching: either answer is exact (DESIGN)
      const bool differ = first->receivers[i].visible(k) != second->receivers[i].visible(k);
      t.differ_any += differ;
      if (ex.margins[i][k] < tau) continue;
      ++t.checked;
      for (const SolveResult* r : rs) t.wrong += r->receivers[i].visible(k) != (cls == 'v');
      t.differ += differ;
    }
  return t;
}

inline std::string describe(const std::map<std::string, std::string>& o) {
  std::string d;
  for (const auto& [k, v] : o) d += k + "=" + v + " ";
  return d.empty() ? "defaults" : d;
}

// Independent reference: orientation tests in double; -1 when some triangle is within
// `eps` (relative to the scene extent cubed) of changing the answer, else 1 blocked /
// 0 visible. Touching never counts here because such relations are skipped.
inline int reference(const Scene& s, const Vec3f& pf, const Vec3f& qf, double eps) {
  AABB b = s.bounds();
  double ext = length(to_double(b.hi) - to_double(b.lo));
  double tol = eps * ext * ext * ext;
  Vec3d p = to_double(pf), q = to_double(qf);
  auto orient = [](const Vec3d& a, const Vec3d& b2, const Vec3d& c, const Vec3d& d) {
    return dot(cross(b2 - a, c - a), d - a);
  };
  int result = 0;
  for (size_t t = 0; t < s.mesh.size(); ++t) {
    Vec3d a = to_double(s.mesh.corner(t, 0)), b2 = to_double(s.mesh.corner(t, 1)), c = to_double(s.mesh.corner(t, 2));
    double s1 = orient(a, b2, c, p), s2 = orient(a, b2, c, q);
    if ((s1 > tol && s2 > tol) || (s1 < -tol && s2 < -tol)) continue;
    double o1 = orient(p, q, a, b2), o2 = orient(p, q, b2, c), o3 = orient(p, q, c, a);
    if ((o1 > tol && o2 > tol && o3 > tol) || (o1 < -tol && o2 < -tol && o3 < -tol)) {
      if (std::abs(s1) <= tol || std::abs(s2) <= tol) return -1;
      result = 1;
      continue;
    }
    bool miss = (o1 > tol || o2 > tol || o3 > tol) && (o1 < -tol || o2 < -tol || o3 < -tol);
    if (!miss) return -1;
  }
  return result;
}

struct Compare {
  size_t checked = 0, mismatches = 0;
};

inline Compare compare_to_reference(const Scene& s, const SolveResult& r, double eps = 1e-9) {
  Compare c;
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    for (size_t l = 0; l < s.lights.size(); ++l) {
      for (int j = 0; j < s.lights[l].samples; ++j) {
        int ref = reference(s, s.receivers[i].p, sample_position(s.lights[l], j, i), eps);
        if (ref < 0) continue;
        ++c.checked;
        bool vis = r.receivers[i].visible(s.light_offset(l) + size_t(j));
        if (vis != (ref == 0)) ++c.mismatches;
      }
    }
  }
  return c;
}



// A box with two random corners o + [-5, 5]^3 (AABB orders them), for the shaft tests.
inline AABB random_box(std::mt19937& rng, const Vec3f& o) {
  std::uniform_real_distribution<float> u(-5, 5);
  Vec3f a, b;
  for (int k = 0; k < 3; ++k) a[k] = u(rng);
  for (int k = 0; k < 3; ++k) b[k] = u(rng);
  return AABB(o + a, o + b);
}

inline double count_visible(const Scene& s, const SolveResult& r) {
  double v = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < s.samples_per_receiver(); ++k) v += r.receivers[i].visible(k);
  return v;
}

// The open tetrahedron of corpus/iss/other/b8a6e1e8...: apex
// (0, 0, 0.5) over the base (0, 0, 0), (0, 2, 0), (-1, 1, 0), which is left open, its
// three faces wound so that they merge into one patch facing the light.
inline void add_open_tetrahedron(Scene& s) {
  s.mesh.vertices = {Vec3f(0, 0, 0.5f), Vec3f(0, 0, 0), Vec3f(0, 2, 0), Vec3f(-1, 1, 0)};
  s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 0, 3}};
}

// A surface of one triangle patch a b c (counter-clockwise as its owner traverses it),
// every edge a boundary edge.
inline iss::Surface one_triangle_surface(const Vec3d& a, const Vec3d& b, const Vec3d& c, iss::Facing facing) {
  iss::Surface s;
  Vec3d v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    iss::RawEdge re;
    re.v[0] = v[k];
    re.v[1] = v[(k + 1) % 3];
    re.nb[1] = 0;
    s.raw.push_back(re);
    s.edges.push_back({uint32_t(k), 0});
    s.hull.extend(v[k]);
  }
  s.patches.push_back({0, 3, facing, -1});
  return s;
}

}  // namespace visgate::test_support
