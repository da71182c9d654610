// visgate solve scene.json --method M [--opt k=v]... [--threads N] [--seed S] [-o result.json]
#include <cstdio>
#include <memory>

#include "lib/external/exec_method.h"
#include "lib/external/external_methods.h"
#include "lib/base/memory_budget.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/scene_json.h"
#include "lib/solver.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct SolveOpts {
  std::string scene, method, out;
  std::vector<std::string> opts;
  int threads = 0;
  uint64_t seed = 1;
  uint64_t memory_budget_mb = 0;
};

int run_solve(const SolveOpts& o) {
  auto solver = make_solver(o.method);
  if (!solver) return bad_input("--method " + external::describe_unknown_method(o.method));
  SolveOptions so;
  so.threads = o.threads;
  so.seed = o.seed;
  so.memory_budget_mb = o.memory_budget_mb;
  for (const auto& kv : o.opts) {
    auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) return bad_input("--opt " + kv + ": expected key=value");
    so.opts[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  Status st = solver->check_options(so);
  if (!st) return bad_input(st.error().message);
  auto scene = read_scene_file(o.scene);
  if (!scene) return bad_input(scene.error().message);
  SolveResult result;
  try {
    result = solver->solve(*scene, so);
  } catch (const external::ExternalMethodError& e) {  // crash, timeout, malformed result
    std::fprintf(stderr, "visgate: method failed: %s\n", e.what());
    return kInternal;
  } catch (const MemoryBudgetExceeded& e) {  // the method's failure, as a timeout (DESIGN section 4): nothing written
    std::fprintf(stderr, "visgate: %s on %s\n", e.what(), o.scene.c_str());
    return kInternal;
  }
  size_t relations = scene->relation_count(), visible = 0;
  for (const auto& rr : result.receivers)
    for (uint64_t w : rr.visible_bits) visible += size_t(__builtin_popcountll(w));
  if (!o.out.empty()) {
    std::string text = write_result_json(*scene, o.method, so, result);
    if (o.out == "-") {
      std::fwrite(text.data(), 1, text.size(), stdout);
    } else {
      Status ws = write_file_atomic(o.out, text);
      if (!ws) return bad_input(ws.error().message);
    }
  }
  std::fprintf(stderr, "%s on %s: %zu relations, %.2f%% visible, %.3f s\n", o.method.c_str(), o.scene.c_str(), relations,
               relations ? 100.0 * double(visible) / double(relations) : 0.0, result.seconds);
  return kOk;
}
}  // namespace

void add_solve(CLI::App& app, Action& run) {
  auto o = std::make_shared<SolveOpts>();
  auto* sub = app.add_subcommand("solve", "Solve every relation of a scene with one method");
  sub->add_option("scene", o->scene, "Scene JSON")->required();
  sub->add_option("--method", o->method, "Method: embree, embree-robust, brute, iss, ssv, plucker-bsp, exec:CMD, plugin:PATH")->required();
  sub->add_option("--opt", o->opts, "Method option key=value (repeatable)");
  sub->add_option("--threads", o->threads, "Threads (0: all)");
  sub->add_option("--seed", o->seed, "Seed for randomised methods");
  sub->add_option("--memory-budget", o->memory_budget_mb,
                  "MB the method's growing structures may hold (iss, ssv, plucker-bsp; 0, the default: half of "
                  "physical memory, at most 8192)");
  sub->add_option("-o,--output", o->out, "Result JSON ('-' for stdout)");
  sub->callback([o, &run] { run = [o] { return run_solve(*o); }; });
}

}  // namespace visgate::cli
