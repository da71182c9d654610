// lib/raycast/brute.h: the brute-force caster against Embree away from degeneracy.
#include <gtest/gtest.h>

#include "lib/raycast/brute.h"
#include "lib/solver.h"
#include "tests/support/family_scene.h"
#include "tests/support/scenes.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(Raycast, BruteAgreesWithEmbreeRobustAwayFromDegeneracy) {
  // Random soups in general position: no shared edges, so float cracks cannot occur;
  // the two casters must agree on all but a vanishing fraction of relations (those
  // within float rounding of an edge). Bound: fewer than 1 in 10^4.
  const Scene scene = family("random-soup", 11, -1, 256, 64);
  ASSERT_FALSE(scene.receivers.empty());
  SolveResult a = make_solver("brute")->solve(scene, SolveOptions{});
  SolveResult b = make_solver("embree-robust")->solve(scene, SolveOptions{});
  size_t differ = 0, total = scene.relation_count();
  for (size_t i = 0; i < a.receivers.size(); ++i)
    for (size_t j = 0; j < scene.samples_per_receiver(); ++j) differ += a.receivers[i].visible(j) != b.receivers[i].visible(j);
  EXPECT_LT(differ * 10000, total) << differ << " of " << total;
}
