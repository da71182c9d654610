// The differential check of the method fuzz targets; see differential.h.
#include "fuzz/differential.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <memory>
#include <string>

#include "fuzz/decoder.h"
#include "fuzz/gmp_pool.h"
#include "lib/external/plugin_method.h"
#include "lib/raycast/embree_solver.h"
#include "lib/scene/scene_json.h"
#include "lib/solver.h"
#include "oracle/comparator.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"

namespace visgate::fuzz {

namespace {

struct Target {
  std::string method;
  std::unique_ptr<Solver> solver;  // nullptr: method not registered in this build
  std::vector<OptionSpec> specs;   // solver->options(), built once (it was 1-2% of a run)
};

Target& target_state(const char* target) {
  static std::map<std::string, Target> targets;
  auto it = targets.find(target);
  if (it != targets.end()) return it->second;
  Target t;
  t.method = target_method(target);
  if (t.method.rfind("plugin:", 0) == 0) {
    // fuzz_plugin: the crash guard off, so that a crash reaches the sanitizers.
    try {
      t.solver = std::make_unique<external::PluginSolver>(t.method.substr(7), false);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", target, e.what());
    }
  } else {
    t.solver = make_solver(t.method);
  }
  if (t.solver)
    t.specs = t.solver->options();
  else if (t.method.empty() && std::string(target) == "fuzz_plugin")
    std::fprintf(stderr, "%s: VISGATE_FUZZ_PLUGIN is not set (the plugin to fuzz); every input returns at once\n", target);
  else
    std::fprintf(stderr, "%s: method '%s' is not registered in this build; every input returns at once\n", target,
                 t.method.c_str());
  return targets.emplace(target, std::move(t)).first->second;
}

std::string options_text(const SolveOptions& opt) {
  std::string s;
  for (const auto& [k, v] : opt.opts) s += (s.empty() ? "" : " ") + k + "=" + v;
  return s.empty() ? "(defaults)" : s;
}

// Prints the report header, the findings and the scene in hex-float, then aborts.
[[noreturn]] void report_and_abort(const char* target, const std::string& method, const SolveOptions& opt,
                                   const Scene& scene, const std::string& findings) {
  std::fprintf(stderr, "==== visgate %s: MISMATCH ====\nmethod: %s\noptions: %s\ntau: %g\n%s", target, method.c_str(),
               options_text(opt).c_str(), kTau, findings.c_str());
  std::fprintf(stderr, "scene (hex-float):\n%s", write_scene_json(scene, SceneWriteOptions{true}).c_str());
  std::fflush(stderr);
  std::abort();
}

char class_char(oracle::RelationClass c) { return char(c); }

}  // namespace

std::vector<size_t> fraction_receivers(uint32_t selector_rest, size_t receivers) {
  if (receivers == 0) return {};
  return {size_t(selector_rest % receivers)};
}

int run_differential(const char* target, const uint8_t* data, size_t size) {
  static const bool gmp_pooled = install_gmp_pool();  // fuzz/gmp_pool.h
  (void)gmp_pooled;
  Target& t = target_state(target);
  if (!t.solver) return 0;
  static ThreadLimit one_thread(1);  // tiny scenes: threads cost more than they save

  static const DecodeLimits limits = target_limits(target);  // one target per process
  auto decoded = decode_case(data, size, limits);
  if (!decoded) return 0;  // malformed or non-finite input, rejected cleanly
  const Scene& scene = decoded->scene;
  SolveOptions opt;
  opt.opts = decode_options(decoded->option_selector, t.specs);
  opt.seed = 1;
  opt.threads = 1;
  if (Status st = t.solver->check_options(opt, t.specs); !st)
    report_and_abort(target, t.method, opt, scene,
                     "decode_options produced options the method rejects: " + st.error().message + "\n");

  // Exact answers first: an exception from the oracle is an oracle bug, reported as such.
  oracle::RelationOracleResult exact;
  try {
    exact = oracle::run_relation_oracle_classes(scene, 1);  // margins below, where read
  } catch (const std::exception& e) {
    report_and_abort(target, "relation oracle", opt, scene, std::string("exception: ") + e.what() + "\n");
  }

  SolveResult result;
  try {
    result = t.solver->solve(scene, opt);
  } catch (const std::exception& e) {
    report_and_abort(target, t.method, opt, scene, std::string("exception from solve: ") + e.what() + "\n");
  }

  // Result shape (DESIGN section 4): one entry per receiver, enough bits, one fraction
  // per light.
  const size_t words = (scene.samples_per_receiver() + 63) / 64;
  if (result.receivers.size() != scene.receivers.size())
    report_and_abort(target, t.method, opt, scene,
                     "result has " + std::to_string(result.receivers.size()) + " receivers, scene has " +
                         std::to_string(scene.receivers.size()) + "\n");
  for (size_t i = 0; i < result.receivers.size(); ++i) {
    const auto& rr = result.receivers[i];
    if (rr.visible_bits.size() < words || rr.visible_fraction.size() != scene.lights.size())
      report_and_abort(target, t.method, opt, scene,
                       "receiver " + std::to_string(i) + ": result has " + std::to_string(rr.visible_bits.size()) +
                           " bit words and " + std::to_string(rr.visible_fraction.size()) + " fractions\n");
  }

  // Embree answered queries blocked without a hit passing the verification filter
  // (EmbreeScene::unverified_hits): rechecked in double, so no answer is wrong, but a
  // kernel skipped the filter; said once per process, with the first run's count.
  static bool unverified_said = false;
  if (const double u = result.stats.get("embree_unverified_hits"); u > 0 && !unverified_said) {
    unverified_said = true;
    std::fprintf(stderr, "%s: NOTE Embree reported %g blocked queries without a verified hit (rechecked in double; "
                         "an Embree kernel skipped the occlusion filter)\n", target, u);
  }

  std::string findings;
  try {
    oracle::fill_disagreement_margins(scene, result, exact);
  } catch (const std::exception& e) {
    report_and_abort(target, "relation oracle", opt, scene, std::string("exception: ") + e.what() + "\n");
  }
  oracle::Comparison cmp = oracle::compare_relations(scene, result, exact, kTau);
  // fuzz_embree: Embree's known robust-mode false hit (the open third-party case in
  // corpus/embree-robust/sliver/) is recorded once and not reported again: a
  // false-blocked relation that Embree with hit verification (EmbreeScene's default,
  // lib/raycast/embree_solver.h) answers visible is that hit. Every other mismatch,
  // including false-visible ones and false hits the double-precision test confirms,
  // still aborts, so the target keeps looking for new kinds of Embree failures.
  std::unique_ptr<raycast::EmbreeScene> verified;
  static size_t known_suppressed = 0;
  for (const auto& m : cmp.mismatches) {
    if (t.method == "embree-robust" && m.direction == oracle::Direction::FalseBlocked && m.sample >= 0) {
      if (!verified) verified = std::make_unique<raycast::EmbreeScene>(scene.mesh, true);
      const Vec3f r = scene.receivers[m.receiver].p;
      const Vec3f l = sample_position(scene.lights[m.light], int(m.sample), m.receiver);
      if (!verified->occluded(r, l)) {
        if (known_suppressed++ == 0)
          std::fprintf(stderr, "%s: known third-party finding (Embree robust-mode false hit, corpus/embree-robust/"
                               "sliver/4c8dae81...) seen; it is counted, not reported again\n", target);
        continue;
      }
    }
    char line[512];
    std::snprintf(line, sizeof line,
                  "mismatch: receiver %zu light %zu sample %ld exact %c method %s margin %.17g direction %s"
                  " exact_fraction %.17g method_fraction %.17g\n",
                  m.receiver, m.light, m.sample, class_char(m.exact), m.method_visible ? "visible" : "blocked",
                  m.margin, oracle::direction_name(m.direction), m.exact_fraction, m.method_fraction);
    findings += line;
  }
  if (cmp.mismatch_count() > 0 && cmp.mismatches.empty())
    findings += "comparator counted " + std::to_string(cmp.mismatch_count()) + " mismatches without records\n";

  // Fragment methods: the visible fractions against the region oracle and one interior
  // point per fragment against the relation oracle, by the comparator's own rules
  // (oracle/comparator.h compare_regions: receivers exactly on a light's plane, where
  // the region oracle reports edge_on and computes no region, are skipped). The
  // fragment check runs on every receiver, the fraction check on the one receiver
  // (every light) the input chooses (fraction_receivers, differential.h).
  if (t.solver->reports_fragments()) {
    std::vector<size_t> all(scene.receivers.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    const std::vector<size_t> chosen =
        fraction_receivers(selector_rest(decoded->option_selector, t.specs), scene.receivers.size());
    oracle::Comparison reg;
    try {
      reg = oracle::compare_regions(scene, result, chosen, kTau, {true, false});
      oracle::merge(reg, oracle::compare_regions(scene, result, all, kTau, {false, true}));
    } catch (const std::exception& e) {
      report_and_abort(target, "region oracle", opt, scene, std::string("exception: ") + e.what() + "\n");
    }
    for (const auto& m : reg.mismatches) {
      char line[320];
      if (m.direction == oracle::Direction::FractionError)
        std::snprintf(line, sizeof line,
                      "mismatch: receiver %zu light %zu direction fraction exact_fraction %.17g method_fraction "
                      "%.17g (tolerance %g)\n",
                      m.receiver, m.light, m.exact_fraction, m.method_fraction, kFractionTolerance);
      else
        std::snprintf(line, sizeof line,
                      "mismatch: receiver %zu light %zu direction %s: a fragment's interior point is blocked, "
                      "margin %.17g\n",
                      m.receiver, m.light, oracle::direction_name(m.direction), m.margin);
      findings += line;
    }
  }
  if (!findings.empty()) report_and_abort(target, t.method, opt, scene, findings);
  return 0;
}

}  // namespace visgate::fuzz
