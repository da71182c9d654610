// Tests of oracle/comparator.cpp: mismatch counts at tau and the region comparison's
// verdicts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cfenv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <tuple>

#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "oracle/comparator.h"
#include "oracle/oracle_json.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tests/support/oracle_scenes.h"

namespace visgate::oracle {
namespace {

using namespace test_support;

TEST(Comparator, DecadeHistogramBoundaries) {
  DecadeHistogram h;
  for (double m : {0.0, 5e-13, 1e-12, 9.9e-12, 1e-5, 0.5, 1.0, 7.0}) h.add(m);
  EXPECT_EQ(h.below, 2u);
  EXPECT_EQ(h.buckets[0], 2u);   // 1e-12, 9.9e-12
  EXPECT_EQ(h.buckets[7], 1u);   // 1e-5
  EXPECT_EQ(h.buckets[11], 1u);  // 0.5
  EXPECT_EQ(h.buckets[12], 2u);  // 1, 7
}

TEST(Comparator, CountsMismatchesOnlyAtOrAboveTau) {
  Scene s;
  s.lights.push_back(explicit_light({{0, 0, 2}, {0, 1, 2}, {1, 1, 2}, {1, 0, 2}},
                                    {{0.1f, 0.1f, 2}, {0.2f, 0.2f, 2}, {0.3f, 0.3f, 2}, {0.4f, 0.4f, 2}, {0.5f, 0.5f, 2}}));
  s.receivers.push_back({{0, 0, 0}, {0, 0, 1}});
  s.receivers.push_back({{1, 1, 0}, {0, 0, 1}});
  RelationOracleResult ex;
  ex.classes = {"vbdvb", "bbvvd"};
  ex.margins = {{1e-3, 1e-3, 0, 1e-7, 2e-5}, {1e-5, 0.5, 1e-13, 1e-2, 0}};
  SolveResult m = make_empty_result(s);
  // Receiver 0 says 1 0 1 0 1: disagrees at samples 3 (v, margin 1e-7: below tau) and 4
  // (b, 2e-5: false-visible). Receiver 1 says 1 0 0 1 1: disagrees at 0 (b, 1e-5 = tau:
  // false-visible) and 2 (v, 1e-13: below tau).
  for (int b : {0, 2, 4}) m.receivers[0].set_visible(size_t(b), true);
  for (int b : {0, 3, 4}) m.receivers[1].set_visible(size_t(b), true);
  Comparison c = compare_relations(s, m, ex, 1e-5);
  EXPECT_EQ(c.relations, 10u);
  EXPECT_EQ(c.degenerate, 2u);
  EXPECT_EQ(c.disagree, 4u);
  EXPECT_EQ(c.agree, 4u);
  EXPECT_EQ(c.false_visible, 2u);
  EXPECT_EQ(c.false_blocked, 0u);
  ASSERT_EQ(c.mismatches.size(), 2u);
  EXPECT_EQ(c.mismatches[0].sample, 4);
  EXPECT_EQ(c.mismatches[1].receiver, 1u);
  EXPECT_EQ(c.disagreement_margins.below, 1u);
  EXPECT_EQ(c.disagreement_margins.buckets[5], 1u);
  auto j = comparison_json(c);
  EXPECT_EQ(j["mismatches"], 2);
  EXPECT_EQ(j["records"].size(), 2u);
  EXPECT_EQ(j["records"][0]["direction"], "false-visible");
}

TEST(Comparator, RegionComparisonFlagsWrongFractionsAndBlockedFragments) {
  Scene s;
  add_quad(s, {0.25f, 0.25f, 1}, {0.5f, 0.25f, 1}, {0.5f, 0.5f, 1}, {0.25f, 0.5f, 1});
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  SolveResult m = make_empty_result(s);
  m.receivers[0].visible_fraction = {0.75f};
  // One correct fragment (visible quarter) and one inside the shadow [0, 0.5]^2.
  m.receivers[0].fragments = {{{{0.5f, 0.5f, 2}, {1, 0.5f, 2}, {1, 1, 2}, {0.5f, 1, 2}},
                               {{0.1f, 0.1f, 2}, {0.4f, 0.1f, 2}, {0.4f, 0.4f, 2}}}};
  Comparison c = compare_regions(s, m, {0}, 1e-5);
  EXPECT_EQ(c.fraction_mismatches, 0u);
  EXPECT_EQ(c.fragment_mismatches, 1u);
  m.receivers[0].visible_fraction = {0.7f};
  EXPECT_EQ(compare_regions(s, m, {0}, 1e-5).fraction_mismatches, 1u);
}

TEST(Comparator, RegionPartsSplitTheRegionComparisonIntoItsTwoChecks) {
  // compare_regions with RegionParts (comparator.h): the fraction check alone and the
  // fragment check alone find exactly the mismatches of the full comparison between them
  // (fuzz_plucker runs the first on one receiver and the second on all).
  Scene s;
  add_quad(s, {0.25f, 0.25f, 1}, {0.5f, 0.25f, 1}, {0.5f, 0.5f, 1}, {0.25f, 0.5f, 1});
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.lights.push_back(square_light_down(-1, 0, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  s.receivers.push_back({{0.375f, 0.375f, 0.5f}, {0, 0, 1}});
  SolveResult m = make_empty_result(s);
  // Receiver 0: light 0 fraction right (0.75), a fragment inside the shadow; light 1
  // fraction wrong. Receiver 1 (right under the quad): light 0 fraction wrong.
  m.receivers[0].visible_fraction = {0.75f, 0.5f};
  m.receivers[0].fragments = {{{{0.1f, 0.1f, 2}, {0.4f, 0.1f, 2}, {0.4f, 0.4f, 2}}}, {}};
  m.receivers[1].visible_fraction = {0.9f, 1.0f};
  const std::vector<size_t> both = {0, 1};
  Comparison full = compare_regions(s, m, both, 1e-5);
  Comparison fr = compare_regions(s, m, both, 1e-5, RegionParts{true, false});
  Comparison fg = compare_regions(s, m, both, 1e-5, RegionParts{false, true});
  EXPECT_EQ(full.fraction_mismatches, 2u);
  EXPECT_EQ(full.fragment_mismatches, 1u);
  EXPECT_EQ(fr.fraction_mismatches, full.fraction_mismatches);
  EXPECT_EQ(fr.fragment_mismatches, 0u);
  EXPECT_EQ(fg.fraction_mismatches, 0u);
  EXPECT_EQ(fg.fragment_mismatches, full.fragment_mismatches);
  merge(fr, fg);
  ASSERT_EQ(fr.mismatches.size(), full.mismatches.size());
  auto key = [](const Mismatch& x) { return std::tuple(x.receiver, x.light, int(x.direction), x.margin); };
  std::vector<std::tuple<size_t, size_t, int, double>> a, b;
  for (const auto& x : fr.mismatches) a.push_back(key(x));
  for (const auto& x : full.mismatches) b.push_back(key(x));
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b);
  // One receiver only: its fraction mismatches, none of the other's.
  Comparison one = compare_regions(s, m, {1}, 1e-5, RegionParts{true, false});
  ASSERT_EQ(one.fraction_mismatches, 1u);
  EXPECT_EQ(one.mismatches[0].receiver, 1u);
}

TEST(RegionOracle, ComparatorVerdictsEqualTheExactOnes) {
  // compare_regions decides most pairs from the certified bound; its fraction verdicts
  // must be those of the exact test !(|mf - exact| <= 1e-4), also for method fractions
  // just inside and just outside the tolerance.
  std::vector<Scene> scenes = bound_scenes();
  size_t checked = 0, mism = 0;
  for (size_t s = 0; s < scenes.size(); s += 3) {
    const Scene& sc = scenes[s];
    std::vector<std::vector<double>> exact(sc.receivers.size(), std::vector<double>(sc.lights.size()));
    std::vector<std::vector<bool>> on(sc.receivers.size(), std::vector<bool>(sc.lights.size()));
    for (size_t i = 0; i < sc.receivers.size(); ++i)
      for (size_t l = 0; l < sc.lights.size(); ++l) {
        RegionAnswer a = visible_region(sc, i, l);
        exact[i][l] = a.visible_fraction;
        on[i][l] = a.edge_on;
      }
    for (double off : {0.0, 3e-5, -9.99e-5, 1e-4, -1e-4, 1.0001e-4, -2e-4, 0.3}) {
      SolveResult m;
      m.receivers.resize(sc.receivers.size());
      std::vector<size_t> all;
      size_t expect = 0;
      for (size_t i = 0; i < sc.receivers.size(); ++i) {
        all.push_back(i);
        for (size_t l = 0; l < sc.lights.size(); ++l) {
          float mf = float(exact[i][l] + off);
          m.receivers[i].visible_fraction.push_back(mf);
          if (!on[i][l] && !(std::abs(double(mf) - exact[i][l]) <= kFractionTolerance)) ++expect;
        }
      }
      Comparison c = compare_regions(sc, m, all, 1e-5);
      EXPECT_EQ(c.fraction_mismatches, expect) << "scene " << s << " offset " << off;
      checked += sc.receivers.size() * sc.lights.size();
      mism += expect;
    }
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_GT(mism, 100u);
}

}  // namespace
}  // namespace visgate::oracle
