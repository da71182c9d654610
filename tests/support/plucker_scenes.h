// Test fixtures of the plucker-bsp suites (tests/plucker/*_test.cpp): hand-made scenes
// under a square light, the solve with test options (one or every combination), and the
// region oracle as the reference for fractions.
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "lib/plucker/plucker_solver.h"
#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "lib/scene/shapes.h"
#include "oracle/region_oracle.h"

namespace visgate::test_support {

// Square light [-1,1]^2 (centre c) at height c.z emitting down, one receiver per point.
// An n x n grid of receivers on the plane z = 0, from (start, start) in steps of `step`.
inline std::vector<Vec3f> receiver_square(int n, float start, float step) {
  std::vector<Vec3f> rec;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) rec.push_back(Vec3f(start + step * float(a), start + step * float(b), 0.0f));
  return rec;
}

inline Scene light_scene(const std::vector<Vec3f>& receivers, int samples = 64, Vec3d c = Vec3d(0, 0, 2)) {
  Scene s;
  s.name = "hand";
  s.lights.push_back(make_square_light_down(c, 1.0, samples, 7));
  for (const Vec3f& p : receivers) s.receivers.push_back({p, Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

inline SolveResult run(const Scene& s, std::map<std::string, std::string> opts = {}, uint64_t seed = 1,
                std::vector<double>* irr = nullptr) {
  SolveOptions o;
  o.opts = std::move(opts);
  o.seed = seed;
  o.threads = 2;
  return plucker::solve_plucker(s, o, irr);
}

// A generated family scene (lib/scene/families.h); -1: the family's default.
inline Result<Scene> family_scene(const char* family, uint64_t seed, long triangles, long receivers,
                                  long samples = -1) {
  FamilyParams p;
  p.seed = seed;
  p.triangles = triangles;
  p.receivers = receivers;
  p.samples = samples;
  return generate_family(family, p);
}

// One solve of s per combination of the values in `vary` (e.g. coherence on and off,
// choice random and relevant), with the options in `fixed` besides; check(result, what)
// for each, `what` naming the combination for failure messages.
template <class F>
void for_each_solve(const Scene& s, const std::vector<std::pair<std::string, std::vector<std::string>>>& vary,
                    const std::map<std::string, std::string>& fixed, F check) {
  std::vector<size_t> at(vary.size(), 0);
  for (;;) {
    std::map<std::string, std::string> opts = fixed;
    std::string what;
    for (size_t k = 0; k < vary.size(); ++k) {
      opts[vary[k].first] = vary[k].second[at[k]];
      what += (k ? " " : "") + vary[k].first + "=" + vary[k].second[at[k]];
    }
    check(run(s, opts), what);
    size_t k = 0;
    while (k < vary.size() && ++at[k] == vary[k].second.size()) at[k++] = 0;
    if (k == vary.size()) return;
  }
}

// Every receiver's fraction of light 0 within `tol` (default: the fraction tolerance
// 1e-4) of the region oracle's; receivers on the light's plane (edge_on: no region) are
// skipped. `what` names the run in failure messages. Returns how many receivers see the
// light partly (exact fraction in (0.01, 0.99)), for tests that need such receivers.
inline int expect_fractions_match_region_oracle(const Scene& s, const SolveResult& r, const std::string& what,
                                                double tol = 1e-4) {
  int partial = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    const auto exact = oracle::visible_region(s, i, 0);
    if (exact.edge_on) continue;
    partial += exact.visible_fraction > 0.01 && exact.visible_fraction < 0.99;
    EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact.visible_fraction, tol) << what << " receiver " << i;
  }
  return partial;
}

// Bits and fractions of two solves of the same scene: the visible regions are the same
// set, so the fractions agree up to the rounding of differently cut fragments.
inline void expect_same_answers(const Scene& s, const SolveResult& a, const SolveResult& b) {
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t li = 0; li < s.lights.size(); ++li) {
      EXPECT_NEAR(a.receivers[i].visible_fraction[li], b.receivers[i].visible_fraction[li], 1e-6) << i << " " << li;
      for (int j = 0; j < s.lights[li].samples; ++j) {
        const size_t bit = s.light_offset(li) + size_t(j);
        EXPECT_EQ(a.receivers[i].visible(bit), b.receivers[i].visible(bit)) << i << " " << li << " " << j;
      }
    }
}

// Every receiver's fraction of every light within 1e-4 of the region oracle's (receivers
// on a light's plane skipped).
inline void expect_region_oracle(const Scene& s, const SolveResult& r) {
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t li = 0; li < s.lights.size(); ++li) {
      const oracle::RegionAnswer reg = oracle::visible_region(s, i, li);
      if (reg.edge_on) continue;
      EXPECT_NEAR(r.receivers[i].visible_fraction[li], reg.visible_fraction, 1e-4) << i << " " << li;
    }
}

}  // namespace visgate::test_support
