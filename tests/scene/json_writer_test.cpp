// lib/scene/json_writer.h and the streamed answer writers: the text must equal, byte
// for byte, nlohmann::ordered_json's dump() of the document the writers used to build.
// The DOM writers live on here as the references.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "lib/scene/json_writer.h"
#include "lib/solver.h"
#include "tests/support/family_scene.h"

namespace visgate {
namespace {

using json = nlohmann::ordered_json;

// The result writer as it was: a whole ordered_json document, dumped.
std::string dom_result_json(const Scene& scene, const std::string& method, const SolveOptions& opt,
                            const SolveResult& result) {
  json doc;
  doc["format"] = "visgate-result";
  doc["version"] = 1;
  doc["method"] = method;
  json o = json::object();
  for (const auto& [k, v] : opt.opts) o[k] = v;
  doc["options"] = o;
  doc["seed"] = opt.seed;
  json recs = json::array();
  size_t bits = scene.samples_per_receiver();
  for (const auto& rr : result.receivers) {
    json r;
    std::string vis(bits, '0');
    for (size_t b = 0; b < bits; ++b)
      if (rr.visible(b)) vis[b] = '1';
    r["visible"] = vis;
    json fr = json::array();
    for (float f : rr.visible_fraction) fr.push_back(double(f));
    r["visible_fraction"] = fr;
    if (!rr.fragments.empty()) {
      json frags = json::array();
      for (const auto& per_light : rr.fragments) {
        json pl = json::array();
        for (const auto& poly : per_light) {
          json pj = json::array();
          for (const auto& p : poly) pj.push_back({double(p.x), double(p.y), double(p.z)});
          pl.push_back(pj);
        }
        frags.push_back(pl);
      }
      r["fragments"] = frags;
    }
    recs.push_back(std::move(r));
  }
  doc["receivers"] = std::move(recs);
  json st = json::object();
  for (const auto& [k, v] : result.stats.sorted()) st[std::string(k)] = v;
  doc["stats"] = st;
  doc["seconds"] = result.seconds;
  return doc.dump() + "\n";
}

void expect_same_result_text(const Scene& scene, const std::string& method, const SolveOptions& opt,
                             const SolveResult& result) {
  const std::string streamed = write_result_json(scene, method, opt, result);
  EXPECT_EQ(streamed, dom_result_json(scene, method, opt, result)) << scene.name << " " << method;
  EXPECT_TRUE(json::accept(streamed)) << scene.name << " " << method;
}

// Floats whose doubles take every shape of nlohmann's number text: integers ("3.0"),
// plain and exponent forms, the longest digit strings, subnormals, signed zero, extremes.
const float kOddFloats[] = {0.0f, -0.0f, 1.0f, 3.0f, -2.5f, 0.1f, 1.0f / 3.0f, 1e-5f, -1.2345678e-7f, 123456.79f,
                            1e15f, 1e16f, 3.4028235e38f, -3.4028235e38f, 1.17549435e-38f, 1.4e-45f, -1.4e-45f,
                            std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN()};

TEST(ResultJson, StreamedEqualsTheDomDumpForEveryMethodOnFamilies) {
  // Small scenes of several families; plucker-bsp writes fragments, the others none.
  size_t polygons = 0;
  for (const char* family : {"columns", "torus", "pouch", "far-origin", "shared-edge-fan", "foliage"}) {
    const Scene scene = test_support::family(family, 3, 40, 9, 8);
    for (const std::string method : {"plucker-bsp", "iss", "ssv", "brute"}) {
      auto solver = make_solver(method);
      ASSERT_TRUE(solver);
      SolveOptions opt;
      opt.threads = 1;
      opt.seed = 7;
      SolveResult result = solver->solve(scene, opt);
      for (const auto& rr : result.receivers)
        for (const auto& per_light : rr.fragments) polygons += per_light.size();
      expect_same_result_text(scene, method, opt, result);
    }
  }
  EXPECT_GT(polygons, 0u);
}

TEST(ResultJson, StreamedEqualsTheDomDumpWithOptions) {
  const Scene scene = test_support::family("columns", 5, 40, 4, 8);
  SolveOptions opt;
  opt.threads = 1;
  opt.opts = {{"choice", "random"}, {"coherence", "off"}, {"tile", "2"}};
  auto solver = make_solver("plucker-bsp");
  ASSERT_TRUE(solver);
  ASSERT_TRUE(solver->check_options(opt));
  SolveResult result = solver->solve(scene, opt);
  ASSERT_FALSE(result.receivers.empty());
  EXPECT_FALSE(result.stats.sorted().empty());
  expect_same_result_text(scene, "plucker-bsp", opt, result);
}

TEST(ResultJson, StreamedEqualsTheDomDumpOnOddValues) {
  // Hand-made results: every odd float in fractions, fragment points and stats, the
  // seconds NaN and infinite, fragments that are empty per light or hold an empty polygon,
  // strings that need escaping, the largest seed.
  Scene scene = test_support::family("columns", 1, 40, 4, 8);
  SolveOptions opt;
  opt.seed = std::numeric_limits<uint64_t>::max();
  opt.opts = {{"quote\"key", "back\\slash"}, {"ctl", std::string("\x01\x1f\n\t\b\f\r", 7)}, {"", ""},
              {"utf8 \xc3\xa9", "\xe2\x82\xac \xf0\x9f\x98\x80"}, {"slash/", "</script>"}};
  SolveResult result = make_empty_result(scene);
  ASSERT_EQ(result.receivers.size(), 4u);
  size_t bit = 0;
  for (auto& rr : result.receivers) {
    for (size_t b = 0; b < scene.samples_per_receiver(); b += 3) rr.set_visible((b + bit) % scene.samples_per_receiver(), true);
    ++bit;
  }
  const size_t n = std::size(kOddFloats);
  result.receivers[0].visible_fraction.assign(std::begin(kOddFloats), std::end(kOddFloats));
  result.receivers[1].fragments = {{}};
  result.receivers[2].fragments = {{Polygon3f{}, Polygon3f{Vec3f(0, 0, 0)}}, {}};
  Polygon3f odd;
  for (size_t i = 0; i < n; ++i) odd.push_back(Vec3f(kOddFloats[i], kOddFloats[(i + 7) % n], kOddFloats[(i + 13) % n]));
  result.receivers[3].fragments = {{odd, odd}, {odd}};
  for (size_t i = 0; i < n; ++i) result.stats.set("odd_" + std::to_string(100 + i), double(kOddFloats[i]));
  result.stats.set("a \"quoted\\\" stat\n", 1.0 / 3.0);
  result.stats.set("big", 1e300);
  result.stats.set("tiny", 4.9e-324);
  result.stats.set("count", 120000.0);
  for (double seconds : {std::nan(""), std::numeric_limits<double>::infinity(), 0.0, 12.345678901234567}) {
    result.seconds = seconds;
    expect_same_result_text(scene, "plucker-bsp", opt, result);
  }
}

TEST(ResultJson, StreamedEqualsTheDomDumpWithoutReceivers) {
  Scene scene = test_support::family("columns", 1, 40, 4, 8);
  scene.receivers.clear();
  SolveOptions opt;
  SolveResult result;
  expect_same_result_text(scene, "iss", opt, result);
  result.stats.set("receivers", 0.0);
  expect_same_result_text(scene, "", opt, result);
}

TEST(ResultJson, InvalidUtf8ThrowsAsTheDomDumpDoes) {
  // dump() rejects invalid UTF-8 (strict error handler); the streamed writer keeps that.
  const Scene scene = test_support::family("columns", 1, 40, 4, 8);
  SolveOptions opt;
  opt.opts = {{"bad", "\xff\xfe"}};
  SolveResult result = make_empty_result(scene);
  EXPECT_THROW(dom_result_json(scene, "iss", opt, result), json::type_error);
  EXPECT_THROW(write_result_json(scene, "iss", opt, result), json::type_error);
}

TEST(JsonWriter, ScalarsAndKeysMatchDump) {
  std::string out;
  JsonWriter w(out);
  w.raw('{');
  w.key("k\"\\\x02");
  w.point(0.1, -0.0, std::nan(""));
  w.raw(',');
  w.key("n");
  w.raw('[');
  w.value(int64_t(-42));
  w.raw(',');
  w.value(uint64_t(18446744073709551615ull));
  w.raw(',');
  w.value(true);
  w.raw(',');
  w.value(false);
  w.raw(',');
  w.value(size_t(3));
  w.raw(',');
  w.value(std::string("x\ty"));
  w.raw("]}");
  json doc;
  doc["k\"\\\x02"] = {0.1, -0.0, std::nan("")};
  doc["n"] = {int64_t(-42), uint64_t(18446744073709551615ull), true, false, size_t(3), "x\ty"};
  EXPECT_EQ(out, doc.dump());
}

TEST(JsonWriter, MaxDoubleCharsBoundsEveryDouble) {
  // The reserve bound: the longest texts are negative, 17 digits, three-digit exponent.
  for (double x : {-1.7976931348623157e308, -2.2250738585072014e-308, -4.9406564584124654e-324,
                   -1.2345678901234567e-100, -0.00012345678901234567, -123456789012345.67}) {
    std::string out;
    JsonWriter w(out);
    w.value(x);
    EXPECT_LE(out.size(), JsonWriter::kMaxDoubleChars) << out;
    EXPECT_EQ(out, json(x).dump());
  }
}

}  // namespace
}  // namespace visgate
