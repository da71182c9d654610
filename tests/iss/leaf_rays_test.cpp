// lib/iss/leaf_rays.cpp: the queued leaf rays (ray_queue) give every relation the answer
// the unqueued leaf caster gives, and both agree with the double reference.
#include <gtest/gtest.h>

#include "lib/scene/families.h"
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
      std::map<std::string, std::string> o = {{"leaf_samples", leaf}, {"leaf_receivers", "8"}, {"auto_rays", "off"}};
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
