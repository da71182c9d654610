// The experiment list of `visgate bench` and the driver that runs one experiment and
// writes its report (DESIGN section 10).
#include <cstdio>
#include <thread>

#include "tools/bench/bench.h"

namespace visgate::bench {

const std::vector<Experiment>& experiments() {
  static const std::vector<Experiment> list = [] {
    std::vector<Experiment> v;
    add_oracle_experiments(v);
    add_core_experiments(v);
    add_repair_experiment(v);
    add_paper_experiments(v);
    add_target_experiment(v);
    // Documented order (docs/bench.md).
    const char* order[] = {"speed-accuracy", "complexity", "iss", "iss-target", "ssv", "plucker", "stability", "oracle", "repair", "overhead",
                           "iss-paper", "ssv-paper", "plucker-paper", "scan", "targets"};
    std::vector<Experiment> sorted;
    for (const char* n : order)
      for (auto& e : v)
        if (e.name == n) sorted.push_back(e);
    return sorted;
  }();
  return list;
}

const Experiment* find_experiment(const std::string& name) {
  for (const auto& e : experiments())
    if (e.name == name) return &e;
  return nullptr;
}

Result<WriteOutcome> run_experiment(const BenchOptions& opt, const std::string& scripts_dir,
                                    const std::string& source_dir, Report* report_out) {
  const Experiment* e = find_experiment(opt.experiment);
  if (!e) {
    std::string known;
    for (const auto& x : experiments()) known += (known.empty() ? "" : ", ") + x.name;
    return Error{"unknown experiment '" + opt.experiment + "' (known: " + known + ")"};
  }
  BenchContext ctx(opt);
  Json& o = ctx.report.options;
  o["repeat"] = opt.repeat;
  o["threads_all"] = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  o["quick"] = opt.quick;
  o["budget_seconds"] = opt.budget;
  o["tau"] = opt.tau;
  o["seed"] = opt.seed;
  o["methods_requested"] = opt.methods;
  o["families_requested"] = opt.families;
  o["methods_registered"] = solver_names();
  o["families_registered"] = family_names();
  o["peak_memory"] = peak_memory_mode();
  o["timing"] = "seconds: minimum over the runs of the method's own SolveResult::seconds (solve including its "
                "acceleration structures, excluding loading and mesh preparation); _1t single-threaded, _all with "
                "threads_all threads";
  o["peak_memory_definition"] = std::string(peak_memory_mode()) == std::string("per-run")
                                    ? "MiB added at the run's peak: VmHWM after the run (high-water mark reset "
                                      "before it through /proc/self/clear_refs) minus VmRSS before it"
                                    : "process high-water mark VmHWM (MiB) after the run; methods run in registry order";
  Status st = e->run(ctx);
  ctx.progress.done();
  if (!st) return st.error();
  auto written = write_report(ctx.report, opt.out_dir, scripts_dir, machine_info(), git_commit(source_dir));
  if (report_out) *report_out = std::move(ctx.report);
  return written;
}

}  // namespace visgate::bench
