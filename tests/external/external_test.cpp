// lib/external: exec: and plugin: methods (DESIGN section 4, docs/external-methods.md).
// Answers are checked against hand-worked scenes and the exact relation oracle; failures
// (crash, timeout, exit status, malformed result) against the messages the tools print.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "lib/external/exec_method.h"
#include "lib/external/external_methods.h"
#include "lib/external/plugin_method.h"
#include "lib/scene/families.h"
#include "lib/scene/float_text.h"
#include "lib/scene/scene_json.h"
#include "oracle/comparator.h"
#include "oracle/relation_oracle.h"
#include "tools/harness/check.h"
#include "tests/support/scenes.h"

using namespace visgate;
using visgate::external::ExternalMethodError;

namespace {

namespace fs = std::filesystem;

// The worked quad scene with its blocker (tests/support/scenes.h): a triangle at z = 1
// blocks exactly the four samples with x, y > 0.
Scene quad_scene() {
  Scene s = test_support::quad_scene();
  test_support::add_quad_blocker(s);
  return s;
}

void expect_quad_answer(const SolveResult& r, const std::string& who) {
  ASSERT_EQ(r.receivers.size(), 1u) << who;
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a)
      EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), !(a >= 2 && b >= 2)) << who << " sample " << a << "," << b;
  EXPECT_FLOAT_EQ(r.receivers[0].visible_fraction[0], 12.0f / 16.0f) << who;
}

Scene family(const std::string& name, uint64_t seed, long triangles = 40) {
  FamilyParams p;
  p.seed = seed;
  p.triangles = triangles;
  p.receivers = 16;
  p.samples = 8;
  auto s = generate_family(name, p);
  EXPECT_TRUE(s.ok());
  return *s;
}

// A folder of scripts for one test, removed at the end.
struct Scripts {
  fs::path dir;
  Scripts() {
    char tmpl[] = "/tmp/visgate-external-test-XXXXXX";
    dir = ::mkdtemp(tmpl);
  }
  ~Scripts() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string add(const std::string& name, const std::string& body) {
    fs::path p = dir / name;
    std::ofstream(p) << "#!/bin/sh\n" << body << "\n";
    ::chmod(p.c_str(), 0755);
    return p.string();
  }
  // A copy of a plugin under a name of its own: a crash disables a library for the rest of
  // the process, so each crash test loads its own copy.
  std::string copy_plugin(const std::string& name) {
    fs::path p = dir / name;
    fs::copy_file(VISGATE_TEST_PLUGIN, p);
    return p.string();
  }
};

std::string failure_of(Solver& s, const Scene& scene, const SolveOptions& so = {}) {
  try {
    s.solve(scene, so);
  } catch (const ExternalMethodError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// ---- the explicit scene form ---------------------------------------------------------

TEST(ExternalScene, JitteredLightsStateEveryRelationPoint) {
  // Every relation point of a jittered light is written, bit-exactly, per receiver; the
  // text reads back (visgate ignores relation_points) to the same relations.
  for (const char* fam : {"random-soup", "torus", "far-origin"}) {
    Scene s = family(fam, 3);
    const std::string text = external::write_explicit_scene_json(s);
    auto doc = nlohmann::json::parse(text);
    ASSERT_EQ(doc["lights"].size(), s.lights.size());
    for (size_t l = 0; l < s.lights.size(); ++l) {
      const Light& L = s.lights[l];
      ASSERT_TRUE(doc["lights"][l].contains("relation_points")) << fam;
      const auto& rp = doc["lights"][l]["relation_points"];
      ASSERT_EQ(rp.size(), s.receivers.size());
      for (size_t i = 0; i < s.receivers.size(); ++i) {
        ASSERT_EQ(rp[i].size(), size_t(L.samples));
        for (int j = 0; j < L.samples; ++j) {
          const Vec3f& want = sample_position(L, j, i);
          for (int a = 0; a < 3; ++a)
            ASSERT_EQ(std::strtof(rp[i][j][a].dump().c_str(), nullptr), want[a]) << fam << " " << i << " " << j;
        }
      }
    }
    auto back = read_scene_json(text, "explicit.json", ".");
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_FALSE(back->grid.has_value());
    ASSERT_EQ(back->receivers.size(), s.receivers.size());
    ASSERT_EQ(back->mesh.size(), s.mesh.size());
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      EXPECT_EQ(back->receivers[i].p, s.receivers[i].p);
      for (size_t l = 0; l < s.lights.size(); ++l)
        for (int j = 0; j < s.lights[l].samples; ++j)
          EXPECT_EQ(sample_position(back->lights[l], j, i), sample_position(s.lights[l], j, i));
    }
  }
}

TEST(ExternalScene, ExplicitSamplesWithJitterOneGoAsTheyAre) {
  Scene s = quad_scene();
  auto doc = nlohmann::json::parse(external::write_explicit_scene_json(s));
  const auto& L = doc["lights"][0];
  EXPECT_FALSE(L.contains("relation_points"));
  EXPECT_EQ(L["jitter"], 1);
  ASSERT_EQ(L["explicit_samples"].size(), 16u);
  EXPECT_EQ(std::strtof(L["explicit_samples"][5][0].dump().c_str(), nullptr), -0.25f);
}

TEST(ExternalScene, ResultReaderNamesTheBadElement) {
  Scene s = quad_scene();
  auto bad = [&](const std::string& text) {
    auto r = external::read_result_json(text, s, "r.json");
    return r.ok() ? std::string() : r.error().message;
  };
  EXPECT_NE(bad("{").find("r.json: JSON parse error"), std::string::npos);
  EXPECT_NE(bad(R"({"format":"visgate-oracle","version":1})").find("format"), std::string::npos);
  EXPECT_NE(bad(R"({"format":"visgate-result","version":1,"receivers":[]})").find("has 0 entries"), std::string::npos);
  EXPECT_NE(bad(R"({"format":"visgate-result","version":1,"receivers":[{"visible":"0101"}]})")
                .find("receivers[0].visible: has 4 characters, expected 16"),
            std::string::npos);
  EXPECT_NE(bad(R"({"format":"visgate-result","version":1,"receivers":[{"visible":"000000000000000x"}]})")
                .find("visible[15]"),
            std::string::npos);
  EXPECT_NE(bad(R"({"format":"visgate-result","version":1,"receivers":[{"visible":"0000000000000000","visible_fraction":[1.5]}]})")
                .find("visible_fraction[0]"),
            std::string::npos);
  // A well-formed result: the bits as given, fractions from the bits.
  auto ok = external::read_result_json(
      R"({"format":"visgate-result","version":1,"receivers":[{"visible":"1111111111111100"}],"seconds":0.5})", s,
      "r.json");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_TRUE(ok->receivers[0].visible(13));
  EXPECT_FALSE(ok->receivers[0].visible(14));
  EXPECT_FLOAT_EQ(ok->receivers[0].visible_fraction[0], 14.0f / 16.0f);
  EXPECT_EQ(ok->stats.get("reported_seconds"), 0.5);
}

// ---- exec: ------------------------------------------------------------------------------

TEST(ExecMethod, TextbookCasterAnswersTheHandWorkedScene) {
  auto solver = make_solver(std::string("exec:") + VISGATE_MT_EXEC);
  ASSERT_TRUE(solver);
  EXPECT_EQ(solver->name(), std::string("exec:") + VISGATE_MT_EXEC);
  expect_quad_answer(solver->solve(quad_scene(), SolveOptions{}), "exec");
}

TEST(ExecMethod, ExecAndPluginAgreeWithTheOracleAwayFromDegeneracies) {
  // The textbook caster is exact enough on generic scenes: every relation whose margin is
  // at least tau agrees with the exact class, through both ways of running it.
  auto exec = make_solver(std::string("exec:") + VISGATE_MT_EXEC);
  auto plugin = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  ASSERT_TRUE(exec && plugin);
  for (uint64_t seed : {1, 2}) {
    Scene s = family("random-soup", seed);
    auto exact = oracle::run_relation_oracle(s, 1);
    SolveResult a = exec->solve(s, SolveOptions{});
    SolveResult b = plugin->solve(s, SolveOptions{});
    EXPECT_EQ(oracle::compare_relations(s, a, exact, 1e-5).mismatch_count(), 0u) << seed;
    EXPECT_EQ(oracle::compare_relations(s, b, exact, 1e-5).mismatch_count(), 0u) << seed;
    for (size_t i = 0; i < s.receivers.size(); ++i) EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits);
  }
}

TEST(ExecMethod, ScriptWithSpacesInItsCommandGetsBothPathsQuoted) {
  // The command may carry its own arguments; the two paths come after them.
  Scripts d;
  std::string script = d.add("copy result.sh",
                             "[ \"$1\" = one ] || exit 9\n"
                             "cat > \"$3\" <<'EOF'\n"
                             "{\"format\":\"visgate-result\",\"version\":1,\"receivers\":[{\"visible\":\"1111111111000000\"}]}\n"
                             "EOF");
  auto solver = make_solver("exec:'" + script + "' one");
  ASSERT_TRUE(solver);
  SolveResult r = solver->solve(quad_scene(), SolveOptions{});
  EXPECT_TRUE(r.receivers[0].visible(9));
  EXPECT_FALSE(r.receivers[0].visible(10));
  EXPECT_FLOAT_EQ(r.receivers[0].visible_fraction[0], 10.0f / 16.0f);
}

TEST(ExecMethod, FailuresAreReportedAsTheMethodsNeverAsACrash) {
  Scripts d;
  Scene s = quad_scene();
  struct Case {
    std::string body, expect;
  } cases[] = {
      {"echo 'no luck' >&2; exit 3", "exit status 3; stderr: no luck"},
      {"kill -SEGV $$", "crashed: signal 11"},
      {"echo '{' > \"$2\"", "malformed result: result: JSON parse error"},
      {"true", "wrote no result file"},
      {"echo '{\"format\":\"visgate-result\",\"version\":1,\"receivers\":[{\"visible\":\"01\"}]}' > \"$2\"",
       "receivers[0].visible: has 2 characters, expected 16"},
  };
  int k = 0;
  for (const auto& c : cases) {
    std::string path = d.add("case" + std::to_string(k++) + ".sh", c.body);
    auto solver = make_solver("exec:" + path);
    ASSERT_TRUE(solver);
    std::string why = failure_of(*solver, s);
    EXPECT_NE(why.find("exec:" + path + ": "), std::string::npos) << why;
    EXPECT_NE(why.find(c.expect), std::string::npos) << why;
    EXPECT_NE(why.find("(scene hand)"), std::string::npos) << why;
  }
}

TEST(ExecMethod, AHangingProgramIsKilledAtTheTimeout) {
  Scripts d;
  std::string path = d.add("hang.sh", "sleep 30 & sleep 30");
  auto solver = make_solver("exec:" + path);
  SolveOptions so;
  so.opts["timeout"] = "1";
  ASSERT_TRUE(solver->check_options(so).ok());
  const auto t0 = std::chrono::steady_clock::now();
  std::string why = failure_of(*solver, quad_scene(), so);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(why.find("timed out after 1 s"), std::string::npos) << why;
  EXPECT_LT(took, 5.0);
  SolveOptions bad;
  bad.opts["timeout"] = "soon";
  EXPECT_FALSE(solver->check_options(bad).ok());
}

// ---- plugin: ----------------------------------------------------------------------------

TEST(PluginMethod, TextbookCasterAnswersTheHandWorkedScene) {
  auto solver = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  ASSERT_TRUE(solver);
  expect_quad_answer(solver->solve(quad_scene(), SolveOptions{}), "plugin");
  auto example = make_solver(std::string("plugin:") + VISGATE_MT_PLUGIN);
  ASSERT_TRUE(example);
  expect_quad_answer(example->solve(quad_scene(), SolveOptions{}), "example plugin");
}

TEST(PluginMethod, FractionsGivenAreKeptAndCheckedOthersComeFromTheBits) {
  auto solver = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  SolveOptions so;
  so.opts["mode"] = "fraction";
  EXPECT_FLOAT_EQ(solver->solve(quad_scene(), so).receivers[0].visible_fraction[0], 0.25f);
  so.opts["mode"] = "bad-fraction";
  std::string why = failure_of(*solver, quad_scene(), so);
  EXPECT_NE(why.find("outside [0, 1]"), std::string::npos) << why;
}

TEST(PluginMethod, OptionsComeFromTheDescriptor) {
  auto solver = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  SolveOptions so;
  so.opts["mode"] = "crash";
  EXPECT_TRUE(solver->check_options(so).ok());
  so.opts["mode"] = "fly";
  EXPECT_FALSE(solver->check_options(so).ok());
  SolveOptions unknown;
  unknown.opts["leaf_samples"] = "4";
  EXPECT_FALSE(solver->check_options(unknown).ok());
}

TEST(PluginMethod, AnErrorStatusIsReportedWithItsReason) {
  auto solver = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  SolveOptions so;
  so.opts["mode"] = "error";
  std::string why = failure_of(*solver, quad_scene(), so);
  EXPECT_NE(why.find("solve returned 7: refused on purpose"), std::string::npos) << why;
  so.opts["mode"] = "mt";  // the library still works
  expect_quad_answer(solver->solve(quad_scene(), so), "after an error");
}

TEST(PluginMethod, ACrashIsCaughtAndDisablesOnlyThatLibrary) {
  Scripts d;
  for (const char* mode : {"crash", "abort"}) {
    const std::string copy = d.copy_plugin(std::string("crashing-") + mode + ".so");
    auto solver = make_solver("plugin:" + copy);
    ASSERT_TRUE(solver);
    SolveOptions so;
    so.opts["mode"] = mode;
    std::string why = failure_of(*solver, quad_scene(), so);
    EXPECT_NE(why.find("plugin:" + copy + ": crashed: signal " + (std::string(mode) == "crash" ? "11" : "6")),
              std::string::npos)
        << why;
    so.opts["mode"] = "mt";
    why = failure_of(*solver, quad_scene(), so);
    EXPECT_NE(why.find("disabled: it crashed earlier"), std::string::npos) << why;
  }
  // The original library is another one and still answers.
  auto fine = make_solver(std::string("plugin:") + VISGATE_TEST_PLUGIN);
  expect_quad_answer(fine->solve(quad_scene(), SolveOptions{}), "other library");
}

TEST(PluginMethod, LoadErrorsNameTheLibrary) {
  EXPECT_FALSE(make_solver("plugin:/nonexistent/libnothing.so"));
  EXPECT_NE(external::describe_unknown_method("plugin:/nonexistent/libnothing.so").find("cannot load"), std::string::npos);
  // A real library without the symbol.
  EXPECT_FALSE(make_solver("plugin:libm.so.6"));
  EXPECT_NE(external::describe_unknown_method("plugin:libm.so.6").find("exports no visgate_method_v1"), std::string::npos);
  EXPECT_NE(external::describe_unknown_method("brutal").find("exec:CMD, plugin:PATH"), std::string::npos);
  EXPECT_FALSE(make_solver("exec:  "));
}

TEST(PluginMethod, WrappedEmbreeGivesTheBuiltInsBits) {
  // The embree-wrapping plugin rebuilds the scene from the flat arrays (lights from their
  // pattern and seed): the same relations, so the same bits as the built-in.
  auto wrapped = make_solver(std::string("plugin:") + VISGATE_EMBREE_PLUGIN);
  auto builtin = make_solver("embree");
  ASSERT_TRUE(wrapped && builtin);
  for (const char* fam : {"torus", "shared-edge-fan", "rooms"}) {
    Scene s = family(fam, 2, 200);
    SolveResult a = wrapped->solve(s, SolveOptions{}), b = builtin->solve(s, SolveOptions{});
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << fam << " receiver " << i;
      EXPECT_EQ(a.receivers[i].visible_fraction, b.receivers[i].visible_fraction) << fam << " receiver " << i;
    }
  }
  expect_quad_answer(wrapped->solve(quad_scene(), SolveOptions{}), "wrapped embree");
}

// ---- the harness keeps the other methods' results ---------------------------------------

TEST(ExternalHarness, FailingMethodsAreErrorsAndTheOthersAreStillChecked) {
  Scripts d;
  const std::string crash = d.copy_plugin("harness-crash.so");
  const std::string hang = d.add("hang.sh", "sleep 30");
  harness::CheckConfig cfg;
  cfg.threads = 1;
  cfg.metamorphic = false;
  auto spec = [](const std::string& name) {
    harness::MethodSpec m;
    m.name = name;
    return m;
  };
  harness::MethodSpec brute = spec("brute"), crashing = spec("plugin:" + crash), hanging = spec("exec:" + hang);
  harness::MethodSpec exec_mt = spec(std::string("exec:") + VISGATE_MT_EXEC);
  crashing.options.opts["mode"] = "crash";
  hanging.options.opts["timeout"] = "1";
  cfg.methods = {crashing, brute, hanging, exec_mt};
  harness::CheckReport report;
  harness::SceneOrigin origin;
  origin.family = "random-soup";
  Scene s = family("random-soup", 1);
  harness::check_scene(s, origin, cfg, report);
  ASSERT_EQ(report.errors.size(), 2u);
  EXPECT_NE(report.errors[0].find("method plugin:" + crash + " threw: plugin:" + crash + ": crashed"), std::string::npos)
      << report.errors[0];
  EXPECT_NE(report.errors[1].find("timed out after 1 s"), std::string::npos) << report.errors[1];
  // Brute and the exec caster were checked in full.
  EXPECT_EQ((report.rows[{"random-soup", "brute"}].relations), s.relation_count());
  EXPECT_EQ((report.rows[{"random-soup", std::string("exec:") + VISGATE_MT_EXEC}].relations), s.relation_count());
}
