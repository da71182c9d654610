// visgate solve scene.json --method M [--opt k=v]... [--threads N] [--memory-budget MB] [--seed S] [-o result.json]
#include <cstdio>

#include "lib/base/memory_budget.h"
#include "lib/external/exec_method.h"
#include "lib/external/external_methods.h"
#include "lib/scene/scene_json.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct SolveOpts {
  std::string scene, out;
  MethodArgs m;
  void bind(CLI::App* sub) {
    sub->add_option("scene", scene, "Scene JSON")->required();
    add_method_args(sub, m, {"Method: embree, embree-robust, brute, iss, ssv, plucker-bsp, exec:CMD, plugin:PATH"});
    sub->add_option("-o,--output", out, "Result JSON ('-' for stdout)");
  }
};

int run_solve(const SolveOpts& o) {
  auto method = make_method(o.m);
  if (!method) return bad_input(method.error());
  auto scene = read_scene_file(o.scene);
  if (!scene) return bad_input(scene.error());
  SolveResult result;
  try {
    result = method->solver->solve(*scene, method->options);
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
    Status st = write_output(o.out, write_result_json(*scene, o.m.method, method->options, result));
    if (!st) return bad_input(st.error());
  }
  std::fprintf(stderr, "%s on %s: %zu relations, %.2f%% visible, %.3f s\n", o.m.method.c_str(), o.scene.c_str(),
               relations, relations ? 100.0 * double(visible) / double(relations) : 0.0, result.seconds);
  return kOk;
}
}  // namespace

void add_solve(CLI::App& app, Action& run) {
  add_command<SolveOpts>(app, run, "solve", "Solve every relation of a scene with one method", run_solve);
}

}  // namespace visgate::cli
