// visgate bench EXPERIMENT [-o DIR] [--repeat N] [--threads N] [--quick] [--quiet]
//                          [--methods a,b] [--families f,g] [--budget S] [--tau T] [--seed S]
// Runs one experiment of tools/bench (DESIGN section 10) and writes DIR/<experiment>.json,
// one CSV per table and the charts (PNG and SVG). Tables go to stderr as text unless
// --quiet; progress shows when stderr is a terminal.
#include <cstdio>
#include <cstdlib>

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
  static constexpr const char* kHelp = "Measure methods side by side: CSV, JSON and charts (DESIGN section 10)";
  bench::BenchOptions b;
  std::string methods, families;
  bool list = false;
  BenchOpts() { b.budget = -1; }  // -1: the default for the chosen sizes
  void bind(CLI::App* sub) {
    sub->add_option("experiment", b.experiment,
                    "speed-accuracy, complexity, iss, ssv, plucker, stability, oracle, repair, overhead (see --list)");
    sub->add_option("-o,--output", b.out_dir, "Output directory (default bench-results/EXPERIMENT)");
    sub->add_option("--repeat", b.repeat, "Runs per figure; the minimum counts (default 3)");
    sub->add_option("--threads", b.threads, "Threads of the all-threads runs (0: all hardware threads)");
    sub->add_flag("--quick", b.quick, "CI-smoke sizes (seconds)");
    sub->add_flag("--quiet", b.quiet, "No progress, notes or tables on stderr");
    sub->add_option("--methods", methods, "Comma-separated methods (default: every registered method)");
    sub->add_option("--families", families, "Comma-separated families (default: the experiment's own)");
    sub->add_option("--budget", b.budget,
                    "Seconds per run before a sweep stops growing for a method (default 60; 5 with --quick)");
    sub->add_option("--memory-budget", b.memory_budget_mb,
                    "MB a method's growing structures may hold; a run past it is a noted skip (0, the default: half "
                    "of physical memory, at most 8192)");
    sub->add_option("--tau", b.tau, "Mismatch margin threshold (default 1e-5)");
    sub->add_option("--seed", b.seed, "Scene and method seed (default 1)");
    sub->add_flag("--list", list, "List the experiments and exit");
  }
};

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
  o.b.methods = split_list(o.methods);
  o.b.families = split_list(o.families);
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

void add_bench(CLI::App& app, Action& run) { add_command<BenchOpts>(app, run, "bench", BenchOpts::kHelp, run_bench); }

}  // namespace visgate::cli
