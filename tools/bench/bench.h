// `visgate bench EXPERIMENT -o DIR` (DESIGN sections 7 and 10): the experiments and what
// they share. Every experiment measures whatever methods the registry (solver_names())
// and families (family_names()) hold when it runs, side by side in one process on the
// same scenes, and skips with a note a method or family it wants but cannot find.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "lib/scene/families.h"
#include "lib/solver.h"
#include "tools/bench/measure.h"
#include "tools/bench/report.h"

namespace visgate::bench {

struct BenchOptions {
  std::string experiment;
  std::string out_dir;
  int repeat = 3;           // runs per figure; the minimum counts
  int threads = 0;          // thread count of the all-threads runs (0: hardware)
  bool quick = false;       // CI-smoke sizes (seconds)
  bool quiet = false;       // no progress, no notes on stderr
  bool progress = false;    // progress line on stderr (set when it is a terminal)
  double budget = 60.0;     // seconds per run before sweeps stop growing for a method
  double tau = 1e-5;        // mismatch margin threshold (DESIGN section 5)
  uint64_t memory_budget_mb = 0;  // SolveOptions::memory_budget_mb of the runs (0: the default)
  uint64_t seed = 1;
  std::vector<std::string> methods;   // empty: every registered method
  std::vector<std::string> families;  // empty: the experiment's own list
};

// Progress line on stderr ("\r[experiment] 3 done, 12.4 s: embree columns N=64"),
// drawn only when enabled; cleared by done().
class Progress {
 public:
  Progress(bool enabled, std::string experiment);
  void step(const std::string& what);
  void done();

 private:
  bool enabled_;
  std::string experiment_;
  size_t count_ = 0;
  double start_ = 0.0;
  bool dirty_ = false;
};

class BenchContext {
 public:
  explicit BenchContext(const BenchOptions& o);

  const BenchOptions& opt;
  Report report;
  Progress progress;

  // Adds a note to the report and prints it on stderr (unless --quiet).
  void note(const std::string& text);
  // The methods to measure: the registry order, restricted to --methods; a requested
  // method that is not registered is noted and skipped.
  std::vector<std::string> methods();
  // `wanted` restricted to --families (when given) and to registered families; every
  // family left out is noted.
  std::vector<std::string> families(const std::vector<std::string>& wanted);
  // True when `method` is registered; otherwise notes "<method> is not registered:
  // <what> skipped" once.
  bool has_method(const std::string& method, const std::string& what);
  // A solver by name, nullptr (with a note) when the registry lacks it.
  std::unique_ptr<Solver> solver(const std::string& method);
  // The measurement configuration of this run.
  MeasureConfig measure_config() const;
  // Generates a family scene; an error names the family and parameters.
  Result<Scene> scene(const std::string& family, const FamilyParams& p);

 private:
  std::vector<std::string> noted_;
};

// Generic descriptions of a scene for tables: triangles, lights, receivers, samples
// per receiver, relations.
Json scene_summary(const Scene& s);

// A method's Stats value by the first present key among `keys`, else NaN.
double stat_or_nan(const Stats& s, const std::vector<std::string>& keys);

struct Experiment {
  std::string name;
  std::string help;
  std::function<Status(BenchContext&)> run;
};
// Every experiment of this build, in the order `visgate bench --help` lists them.
const std::vector<Experiment>& experiments();
const Experiment* find_experiment(const std::string& name);

// The experiments that need no oracle (experiments_core.cpp) and those that do
// (experiments_oracle.cpp).
void add_core_experiments(std::vector<Experiment>& out);
void add_oracle_experiments(std::vector<Experiment>& out);
// The mesh repair throughput experiment (experiments_repair.cpp).
void add_repair_experiment(std::vector<Experiment>& out);
// The paper-scale experiments iss-paper, ssv-paper, plucker-paper and scan
// (experiments_paper.cpp).
void add_paper_experiments(std::vector<Experiment>& out);
// The speed targets with their verdicts (experiments_targets.cpp).
void add_target_experiment(std::vector<Experiment>& out);

// Runs one experiment and writes its report to opt.out_dir. Returns the files written;
// the report itself goes to `report_out` when given.
Result<WriteOutcome> run_experiment(const BenchOptions& opt, const std::string& scripts_dir,
                                    const std::string& source_dir, Report* report_out = nullptr);

}  // namespace visgate::bench
