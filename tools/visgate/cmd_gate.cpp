// visgate gate [--quick] [-o DIR] [--corpus DIR] [--threads N] [--method M]... [--opt M:key=value]...
// The CI correctness gate (tools/harness/gate.h): prints a summary table on stderr and
// writes DIR/gate.json, DIR/stability.csv and the chart DIR/stability.png and .svg
// (gnuplot, tools/plot_stability.gp). Exit: 0 passed, 1 failed, 2 bad input.
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "lib/scene/json_exact.h"
#include "tools/harness/gate.h"
#include "tools/visgate/cli.h"

#ifndef VISGATE_SOURCE_DIR
#define VISGATE_SOURCE_DIR "."
#endif

namespace visgate::cli {

namespace {
struct GateOpts {
  static constexpr const char* kHelp =
      "The CI correctness gate: every family and method, metamorphic checks, corpus replay";
  bool quick = false;
  std::string out = "out/gate", corpus = VISGATE_SOURCE_DIR "/corpus";
  int threads = 0;
  std::vector<std::string> methods, opts;  // extra gated methods (exec:, plugin:, built-ins) and their options
  void bind(CLI::App* sub) {
    sub->add_flag("--quick", quick, "The quick gate (twelve seeds per family, small scenes; under 3 minutes on 2 cores)");
    sub->add_option("-o,--output", out, "Output folder (default out/gate)");
    sub->add_option("--corpus", corpus, "Corpus root to replay (default the source tree's corpus/)");
    sub->add_option("--threads", threads, "Threads (0: all)");
    sub->add_option("--method", methods,
                    "Also gate this method (repeatable; exec:CMD, plugin:PATH or a built-in): any oracle mismatch or "
                    "failure of it fails the gate");
    sub->add_option("--opt", opts, "Option of a --method: METHOD:key=value (repeatable)");
  }
};

int run_gate_cmd(const GateOpts& o) {
  using namespace visgate::harness;
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return bad_input(o.out + ": cannot create folder: " + ec.message());
  if (o.out.find('\'') != std::string::npos) return bad_input(o.out + ": folder names with ' are not supported");
  ThreadLimit limit(o.threads);
  GateConfig cfg;
  cfg.quick = o.quick;
  cfg.out_dir = o.out;
  cfg.corpus_dir = o.corpus;
  cfg.threads = o.threads;
  for (const auto& m : o.methods) {
    auto spec = method_spec(m, o.opts, o.threads, "--method");
    if (!spec) return bad_input(spec.error());
    cfg.extra_methods.push_back(*spec);
  }
  std::fprintf(stderr, "visgate gate%s: every family x every method (%zu methods), corpus %s\n", o.quick ? " --quick" : "",
               solver_names().size() + o.methods.size(), o.corpus.c_str());
  GateResult g = run_gate(cfg, [](const std::string& line) { std::fprintf(stderr, "  %s\n", line.c_str()); });

  // Chart: CSV, then gnuplot to PNG and SVG.
  std::string csv = o.out + "/stability.csv";
  Status st = write_file_atomic(csv, stability_csv(g.report));
  if (!st) return bad_input(st.error());
  std::string methods;
  for (const auto& m : g.report.methods) methods += (methods.empty() ? "" : " ") + m;
  std::string script = VISGATE_SOURCE_DIR "/tools/plot_stability.gp";
  std::string cmd = "gnuplot -e \"csv='" + csv + "'; out='" + o.out + "/stability'; methods='" + methods + "'\" '" +
                    script + "' 2>&1";
  int rc = std::system(cmd.c_str());
  if (rc != 0) g.notes.push_back("stability chart: gnuplot failed (exit " + std::to_string(rc) + "): " + cmd);

  st = write_file_atomic(o.out + "/gate.json", gate_to_json(g));
  if (!st) return bad_input(st.error());
  std::fputs(format_gate_summary(g).c_str(), stderr);
  std::fprintf(stderr, "wrote %s/gate.json, %s, %s/stability.png, %s/stability.svg\n", o.out.c_str(), csv.c_str(),
               o.out.c_str(), o.out.c_str());
  return g.passed() ? kOk : kFound;
}
}  // namespace

void add_gate(CLI::App& app, Action& run) { add_command<GateOpts>(app, run, "gate", GateOpts::kHelp, run_gate_cmd); }

}  // namespace visgate::cli
