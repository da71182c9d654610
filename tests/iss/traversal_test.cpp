// lib/iss/traversal.cpp: automatic ray casting of shafts whose subdivision does not pay.
#include <gtest/gtest.h>

#include <initializer_list>

#include "lib/solver.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

// ---- the exact oracle on the scene families ------------------------------------------------

namespace {

// Every relation is answered exactly once: by a ray, a blocked shaft or an empty shaft.
double relations_answered(const SolveResult& r) {
  return r.stats.get("relations_ray_cast") + r.stats.get("relations_blocked_by_shaft") +
         r.stats.get("relations_visible_by_empty_shaft");
}

}  // namespace

TEST(IssOracle, AutomaticRaysEngageOnColumnsAndMatchTheOracle) {
  // Columns at 1024 receivers: every receiver node sees some column edge-on against the
  // light, so shafts of 16..128 receivers decide nothing and the automatic rule
  // (traversal.h, kAutoRayRelationsPerShaft) casts their relations after the first few. Its answers
  // must match the exact oracle like the full subdivision's, and with the rule off no
  // shaft is skipped.
  const double tau = 1e-5;
  Scene s = family("columns", 3, 2500, 1024, 64);
  ASSERT_FALSE(s.receivers.empty());
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
  SolveResult on = run_iss(s, {}), off = run_iss(s, {{"auto_rays", "off"}});
  EXPECT_GT(on.stats.get("auto_ray_shafts"), 0.0);
  EXPECT_LT(on.stats.get("shafts_built"), off.stats.get("shafts_built"));
  EXPECT_EQ(off.stats.get("auto_ray_shafts"), 0.0);
  EXPECT_EQ(relations_answered(on), double(s.relation_count()));
  const OracleTally t = tally_against_oracle(s, ex, tau, {&on, &off});
  EXPECT_GT(t.checked, s.relation_count() / 2);
  EXPECT_EQ(t.wrong, 0u);
}

TEST(IssOracle, LightSplitChoiceAnswersLikeWholeLightLeavesAndTheOracle) {
  // light_split (traversal.h, LightMode): the trial on columns at this density picks
  // light splits for the light; the answers of auto, on (every light split) and off
  // (whole-light leaves, the previous default) must all match the exact oracle and each
  // other bit for bit away from degenerate relations, and every relation must be decided
  // exactly once.
  const double tau = 1e-5;
  Scene s = family("columns", 3, 2500, 4096, 64);
  ASSERT_FALSE(s.receivers.empty());
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
  SolveResult a = run_iss(s, {}), on = run_iss(s, {{"light_split", "on"}}), off = run_iss(s, {{"light_split", "off"}});
  SolveResult on_full = run_iss(s, {{"light_split", "on"}, {"auto_rays", "off"}});
  EXPECT_EQ(a.stats.get("lights_split"), 1.0);
  EXPECT_GT(a.stats.get("light_split_trial_shafts"), 0.0);
  EXPECT_EQ(off.stats.get("lights_split"), 0.0);
  EXPECT_EQ(off.stats.get("light_split_trial_shafts"), 0.0);
  // With every light split and no automatic rays the 4-sample light leaves are reached.
  EXPECT_GT(on_full.stats.get("relations_blocked_by_shaft") + on_full.stats.get("relations_visible_by_empty_shaft"), 0.0);
  for (const SolveResult* r : {&a, &on, &off, &on_full}) EXPECT_EQ(relations_answered(*r), double(s.relation_count()));
  const OracleTally t = tally_against_oracle(s, ex, tau, {&a, &off, &on, &on_full});
  EXPECT_GT(t.checked, s.relation_count() / 2);
  EXPECT_EQ(t.wrong, 0u);
  EXPECT_EQ(t.differ, 0u);
}

TEST(IssOracle, LightSplitTrialKeepsWholeLightsOnRooms) {
  // Rooms' small lights behind walls: the trial keeps whole-light leaves (light splits
  // decide nothing there that rays would not), and the answers match light_split=off.
  Scene s = family("rooms", 3, -1, 256, 16);
  ASSERT_FALSE(s.receivers.empty());
  SolveResult a = run_iss(s, {}), off = run_iss(s, {{"light_split", "off"}});
  EXPECT_EQ(a.stats.get("lights_split"), 0.0);
  size_t differ = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < s.relation_count() / s.receivers.size(); ++k)
      differ += a.receivers[i].visible(k) != off.receivers[i].visible(k);
  EXPECT_EQ(differ, 0u);
}

TEST(IssOracle, SplitLeafOptionsChangeTheTraversalNotTheAnswers) {
  // split_samples, split_receivers and split_auto_ray_relations (iss_solver.cpp) set the
  // leaves and the automatic-ray threshold of split lights, for measuring CHOOSE-SPLIT's
  // balance (docs/log/iss-shafts.md). They must reach the traversal (other shaft and
  // ray counts) and leave every answer as the default's and the exact oracle's.
  const double tau = 1e-5;
  Scene s = family("columns", 3, 2500, 4096, 64);
  ASSERT_FALSE(s.receivers.empty());
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
  SolveResult base = run_iss(s, {{"light_split", "on"}});
  SolveResult varied = run_iss(s, {{"light_split", "on"},
                                   {"split_samples", "8"},
                                   {"split_receivers", "16"},
                                   {"split_auto_ray_relations", "0"}});
  EXPECT_NE(base.stats.get("shafts_built"), varied.stats.get("shafts_built"));
  EXPECT_EQ(varied.stats.get("auto_ray_shafts"), 0.0);  // threshold 0: no shaft is skipped
  EXPECT_EQ(relations_answered(varied), double(s.relation_count()));
  const OracleTally t = tally_against_oracle(s, ex, tau, {&varied, &base});
  EXPECT_GT(t.checked, s.relation_count() / 2);
  EXPECT_EQ(t.wrong, 0u);
  EXPECT_EQ(t.differ, 0u);
}
