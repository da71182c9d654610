// visgate bench EXPERIMENT [-o DIR] [--repeat N] [--threads N] [--quick] [--quiet]
//                          [--methods a,b] [--families f,g] [--budget S] [--tau T] [--seed S]
// Runs one experiment of tools/bench (DESIGN section 10) and writes DIR/<experiment>.json,
// one CSV per table and the charts (PNG and SVG). Tables go to stderr as text unless
// --quiet; progress shows when stderr is a terminal.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>

#include "tools/bench/bench.h"
#include "tools/visgate/cli.h"

#ifndef VISGATE_BENCH_SCRIPTS
#error "VISGATE_BENCH_SCRIPTS (the folder of the gnuplot scripts) must be defined by the build"
#endif
#ifndef VISGATE_SOURCE_DIR
#error "VISGATE_SOURCE_DIR must be defined by the build"
#endif

namespace visgate::cli {

namespace {
struct BenchOpts {
  bench::BenchOptions b;
  std::string methods, families;
  bool list = false;
  BenchOpts() { b.budget = -1; }  // -1: the default for the chosen sizes
};

std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

int run_bench(BenchOpts& o) {
  if (o.list) {
    for (const auto& e : bench::experiments()) std::printf("%-15s %s\n", e.name.c_str(), e.help.c_str());
    return kOk;
  }
  if (o.b.experiment.empty()) return bad_input("bench: EXPERIMENT is required (see --list)");
  if (!bench::find_experiment(o.b.experiment)) {
    std::string known;
    for (const auto& e : bench::experiments()) known += (known.empty() ? "" : ", ") + e.name;
    return bad_input("bench: unknown experiment '" + o.b.experiment + "' (known: " + known + ")");
  }
  if (o.b.repeat < 1) return bad_input("bench: --repeat " + std::to_string(o.b.repeat) + ": expected at least 1");
  if (o.b.threads < 0) return bad_input("bench: --threads " + std::to_string(o.b.threads) + ": expected 0 or more");
  if (o.b.budget < 0) o.b.budget = o.b.quick ? 5.0 : 60.0;
  if (!(o.b.budget > 0)) return bad_input("bench: --budget: expected a positive number of seconds");
  if (!(o.b.tau >= 0)) return bad_input("bench: --tau: expected a non-negative margin");
  o.b.methods = split_commas(o.methods);
  o.b.families = split_commas(o.families);
  if (o.b.out_dir.empty()) o.b.out_dir = "bench-results/" + o.b.experiment;
  o.b.progress = stderr_is_tty();
  const char* env = std::getenv("VISGATE_BENCH_SCRIPTS");
  std::string scripts = env && *env ? env : VISGATE_BENCH_SCRIPTS;
  bench::Report report;
  auto out = bench::run_experiment(o.b, scripts, VISGATE_SOURCE_DIR, &report);
  if (!out) return bad_input("bench " + o.b.experiment + ": " + out.error().message);
  if (!o.b.quiet) {
    for (const auto& t : report.tables) {
      if (t.rows.size() > 80) {
        std::fprintf(stderr, "\n%s: %s (%zu rows: see the CSV)\n", t.name.c_str(), t.caption.c_str(), t.rows.size());
        continue;
      }
      std::fprintf(stderr, "\n%s: %s\n%s", t.name.c_str(), t.caption.c_str(), bench::table_markdown(t).c_str());
    }
    for (const auto& e : out->chart_errors) std::fprintf(stderr, "visgate bench: chart %s\n", e.c_str());
    std::fprintf(stderr, "visgate bench %s: %zu files in %s\n", o.b.experiment.c_str(), out->files.size(),
                 o.b.out_dir.c_str());
  }
  return kOk;
}
}  // namespace

void add_bench(CLI::App& app, Action& run) {
  auto o = std::make_shared<BenchOpts>();
  auto* sub = app.add_subcommand("bench", "Measure methods side by side: CSV, JSON and charts (DESIGN section 10)");
  sub->add_option("experiment", o->b.experiment,
                  "speed-accuracy, complexity, iss, ssv, plucker, stability, oracle, repair, overhead (see --list)");
  sub->add_option("-o,--output", o->b.out_dir, "Output directory (default bench-results/EXPERIMENT)");
  sub->add_option("--repeat", o->b.repeat, "Runs per figure; the minimum counts (default 3)");
  sub->add_option("--threads", o->b.threads, "Threads of the all-threads runs (0: all hardware threads)");
  sub->add_flag("--quick", o->b.quick, "CI-smoke sizes (seconds)");
  sub->add_flag("--quiet", o->b.quiet, "No progress, notes or tables on stderr");
  sub->add_option("--methods", o->methods, "Comma-separated methods (default: every registered method)");
  sub->add_option("--families", o->families, "Comma-separated families (default: the experiment's own)");
  sub->add_option("--budget", o->b.budget,
                  "Seconds per run before a sweep stops growing for a method (default 60; 5 with --quick)");
  sub->add_option("--memory-budget", o->b.memory_budget_mb,
                  "MB a method's growing structures may hold; a run past it is a noted skip (0, the default: half "
                  "of physical memory, at most 8192)");
  sub->add_option("--tau", o->b.tau, "Mismatch margin threshold (default 1e-5)");
  sub->add_option("--seed", o->b.seed, "Scene and method seed (default 1)");
  sub->add_flag("--list", o->list, "List the experiments and exit");
  sub->callback([o, &run] { run = [o] { return run_bench(*o); }; });
}

}  // namespace visgate::cli
