// Tests of oracle/oracle_json.cpp: the oracle output files, written and read back.
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

TEST(OracleJson, RoundTripsClassesAndMargins) {
  Scene s = grid_scene(21, 30, 3, 5);
  RelationOracleResult r = run_relation_oracle(s);
  std::string text = write_oracle_json(s, r, {});
  auto back = read_oracle_json(text, "o.json");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->relations.classes, r.classes);
  EXPECT_EQ(back->relations.margins, r.margins);
  EXPECT_EQ(back->tau, kDefaultTau);
  EXPECT_FALSE(read_oracle_json(R"({"format": "visgate-result", "version": 1})", "x.json").ok());
}

TEST(OracleJson, RegionsFollowTheDesignLayoutAndReadBackBitExactly) {
  Scene s;
  add_quad(s, {0.25f, 0.25f, 1}, {0.5f, 0.25f, 1}, {0.5f, 0.5f, 1}, {0.25f, 0.5f, 1});
  s.lights.push_back(explicit_light({{0, 0, 2}, {0, 1, 2}, {1, 1, 2}, {1, 0, 2}}, {{0.1f, 0.2f, 2}, {0.9f, 0.9f, 2}}));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RelationOracleResult r = run_relation_oracle(s);
  // The region answer with one vertex moved to a float that needs all 9 digits.
  RegionAnswer reg = visible_region(s, 0, 0);
  ASSERT_FALSE(reg.polygons.empty());
  const float odd = std::nextafter(0.1f, 1.0f);
  reg.polygons[0][0].x = odd;
  std::string text = write_oracle_json(s, r, {{reg}});
  auto doc = nlohmann::json::parse(text);
  EXPECT_EQ(doc["format"], "visgate-oracle");
  EXPECT_EQ(doc["version"], 1);
  EXPECT_EQ(doc["tau"].get<double>(), 1e-5);
  const auto& rec = doc["receivers"][0];
  // (0.1, 0.2) is in the shadow [0, 0.5]^2 (crossing the occluder at (0.3, 0.35, 1), off
  // the quad's diagonal), (0.9, 0.9) is not.
  EXPECT_EQ(rec["classes"], "bv");
  EXPECT_EQ(rec["margins"].size(), 2u);
  const auto& g = rec["regions"][0];
  EXPECT_EQ(g["light"], 0);
  EXPECT_EQ(g["visible_fraction"].get<double>(), 0.75);
  std::string dumped = g["polygons"][0][0][0].dump();
  EXPECT_EQ(std::strtof(dumped.c_str(), nullptr), odd) << dumped;
  EXPECT_LE(dumped.size(), 11u) << dumped;  // "0.100000009": 9 significant digits
}

}  // namespace
}  // namespace visgate::oracle
