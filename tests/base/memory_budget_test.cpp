// The memory budget (lib/base/memory_budget.h): the accounting itself, and each
// production method stopping with MemoryBudgetExceeded under a 1 MB budget on a dense
// scan scene (iss: live shafts, ssv: wedges and the wedge BSP, plucker-bsp: BSP nodes
// and occluder lists).
#include <gtest/gtest.h>

#include "lib/base/memory_budget.h"
#include "lib/scene/families.h"
#include "lib/solver.h"

namespace visgate {
namespace {

TEST(MemoryBudget, ChargesReleaseAndThrowPastTheLimit) {
  MemoryBudget b("m", 1);
  {
    MemoryCharge c;
    c.bind(&b, "nodes");
    c.set(600 * 1024);
    MemoryCharge d;
    d.bind(&b, "lists");
    EXPECT_THROW(d.set(600 * 1024), MemoryBudgetExceeded);  // 1200 KB > 1 MB
  }
  // Both released: the whole budget is free again.
  MemoryCharge e;
  e.bind(&b, "nodes");
  EXPECT_NO_THROW(e.set(1000 * 1024));
  EXPECT_NO_THROW(e.set(10));  // shrinking never throws
  try {
    b.change(2 * 1024 * 1024, "wedges");
    FAIL() << "no throw";
  } catch (const MemoryBudgetExceeded& x) {
    EXPECT_EQ(x.method(), "m");
    EXPECT_EQ(x.budget_mb(), 1u);
    EXPECT_NE(std::string(x.what()).find("wedges"), std::string::npos) << x.what();
    EXPECT_NE(std::string(x.what()).find("memory budget of 1 MB"), std::string::npos) << x.what();
  }
}

TEST(MemoryBudget, DefaultIsHalfOfMemoryAtMost8GiB) {
  const uint64_t d = default_memory_budget_mb();
  EXPECT_GT(d, 0u);
  EXPECT_LE(d, 8192u);
  MemoryBudget b("m", 0);
  EXPECT_EQ(b.budget_mb(), d);
}

TEST(MemoryBudget, ProductionMethodsStopUnderATinyBudget) {
  FamilyParams p;
  p.seed = 1;
  // Large enough that plucker-bsp, which keeps one side of a closed surface, still
  // needs well over 1 MB.
  p.triangles = 80000;
  p.receivers = 1024;
  p.samples = 4;
  auto scene = generate_family("scan", p);
  ASSERT_TRUE(scene.ok());
  for (const char* m : {"iss", "ssv", "plucker-bsp"}) {
    auto solver = make_solver(m);
    ASSERT_TRUE(solver) << m;
    SolveOptions o;
    o.threads = 1;
    o.memory_budget_mb = 1;
    // iss would cast this scene's few relations per triangle as leaf rays (dense_rays),
    // holding no growing structure; its shafts are what the budget bounds.
    if (std::string(m) == "iss") o.opts = {{"dense_rays", "off"}};
    try {
      solver->solve(*scene, o);
      ADD_FAILURE() << m << " finished within 1 MB";
    } catch (const MemoryBudgetExceeded& e) {
      EXPECT_EQ(e.method(), m);
      EXPECT_EQ(e.budget_mb(), 1u);
    }
  }
}

}  // namespace
}  // namespace visgate
