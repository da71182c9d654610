// The CI correctness gate (`visgate gate`): fixed seeds over every scene family
// and every registered method, metamorphic checks, the corpus replay, a summary table,
// a JSON report and the stability chart (per method, the disagreement rate per margin
// decade: CSV, then gnuplot to PNG and SVG).
//
// Verdict: fails on any mismatch (including metamorphic) of visgate's own methods
// (iss, ssv, plucker-bsp) or of the oracle's metamorphic checks, on any method of those
// that throws, and on any corpus regression (a fixed entry failing, or the oracle
// changing an entry's exact class). The baselines (embree, embree-robust, brute) are
// measured and shown but never fail the gate. An open corpus entry that now passes is
// reported, not a failure of the gate (the replay suite in ctest flags it).
#pragma once

#include <string>
#include <vector>

#include "tools/harness/check.h"
#include "tools/harness/corpus.h"

namespace visgate::harness {

// Methods whose mismatches fail the gate, and the baselines that never do.
bool gate_method_must_pass(const std::string& method);  // a row label: NAME or NAME#TAG
// The gate's methods: every registered one with default options, and iss#shafts (iss
// with leaves of one receiver and one sample, automatic rays off).
std::vector<MethodSpec> gate_methods();

struct GateConfig {
  bool quick = false;
  std::string out_dir = "out/gate";
  std::string corpus_dir;  // replayed corpus root
  int threads = 0;
  std::string gnuplot_script;  // tools/plot_stability.gp
  // More methods to gate (`visgate gate --method M`: your own exec:/plugin: code or a
  // built-in with options): each fails the gate on any oracle mismatch or failure (a
  // crash, timeout, malformed result). Their metamorphic rows are shown, not gated: the
  // scale contract of DESIGN section 2 binds visgate's own methods.
  std::vector<MethodSpec> extra_methods;
};

struct GateCorpusLine {
  std::string path, method, status;
  ReplayResult result;
};

struct GateResult {
  CheckReport report;
  std::vector<GateCorpusLine> corpus;
  size_t corpus_regressions = 0, corpus_open_now_passing = 0, corpus_skipped = 0;
  std::vector<std::string> failures;  // why the gate fails (empty: passes)
  std::vector<std::string> notes;     // chart problems, open cases now passing
  std::vector<std::string> extra_rows;  // row labels of GateConfig::extra_methods
  double seconds = 0.0;
  bool passed() const { return failures.empty(); }
};

// The scene campaign of the gate: (family, seed, params) per scene.
std::vector<SceneOrigin> gate_campaign(bool quick);

// Runs the gate; `progress` (may be empty) receives one line per scene.
GateResult run_gate(const GateConfig& cfg, const std::function<void(const std::string&)>& progress);

// Human summary table.
std::string format_gate_summary(const GateResult& g);
// The stability CSV: method,decade_index,decade,relations,disagreements,rate.
std::string stability_csv(const CheckReport& r);
// Gate JSON (format "visgate-gate-report"): the check report plus corpus replay and verdict.
std::string gate_to_json(const GateResult& g);

}  // namespace visgate::harness
