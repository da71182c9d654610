// Measuring methods for `visgate bench` (DESIGN section 10): minimum wall time over
// repeated runs, single-threaded and with all threads, and each run's own peak memory.
//
// Peak memory: before every run the process high-water mark is reset (Linux
// /proc/self/clear_refs, value 5, "reset the peak resident set size to the current
// RSS"), and after it VmHWM - VmRSS(before) of /proc/self/status is the memory the run
// added at its peak: the method's own figure, whatever ran before it. Where the reset is
// refused the figure falls back to the process high-water mark VmHWM (monotone over the
// whole process: methods then run in the fixed registry order) and `peak_memory_mode`
// says so in every report.
#pragma once

#include <chrono>
#include <limits>
#include <utility>
#include <map>
#include <string>
#include <vector>

#include "lib/solver.h"

namespace visgate::bench {

// "per-run" when the high-water mark can be reset, else "process-hwm".
const char* peak_memory_mode();
// Resets the high-water mark; false when the kernel refuses.
bool reset_peak_memory();
// VmRSS and VmHWM of /proc/self/status in MiB (0 when unreadable).
double rss_mb();
double hwm_mb();

struct MeasureConfig {
  int repeat = 3;          // runs per thread setting; the minimum counts
  int all_threads = 0;     // thread count of the "all threads" runs (0: hardware)
  bool single = true;      // run single-threaded
  bool all = true;         // run with all threads
  double budget = 60.0;    // seconds: a run longer than this is not repeated (and a
                           // single-threaded one not rerun with all threads)
};

struct Measured {
  double seconds_1t = std::numeric_limits<double>::quiet_NaN();   // min over runs
  double seconds_all = std::numeric_limits<double>::quiet_NaN();  // min over runs
  int runs_1t = 0, runs_all = 0;
  // Process CPU seconds of the whole solve() call (CLOCK_PROCESS_CPUTIME_ID; includes
  // what `seconds` leaves out, e.g. ISS's mesh preparation), min over the single-
  // threaded runs. On a machine shared with other work, wall time includes the time
  // slices other processes take; CPU time of a single-threaded run does not.
  double cpu_1t = std::numeric_limits<double>::quiet_NaN();
  double peak_mb = 0.0;  // max over runs of the run's own peak (see file comment)
  SolveResult result;    // the first run's answer (bits, fractions, fragments)
  Stats stats;           // the first run's stats
  // Best available time: single-threaded when measured, else all threads.
  double seconds() const { return runs_1t ? seconds_1t : seconds_all; }
};

// `cfg` for one single-threaded run per call (the rounds of the interleaved measurements
// below and of the iss doubling experiment).
MeasureConfig single_run(MeasureConfig cfg);

// Runs `solver` on `scene` (1 thread, then all threads) as configured. Time is the
// method's own SolveResult::seconds (DESIGN section 4: the solve including its
// acceleration structures, excluding loading and mesh preparation); a method that
// leaves it 0 is timed around the call instead.
Measured measure_solve(Solver& solver, const Scene& scene, const SolveOptions& base, const MeasureConfig& cfg);

// Two solvers measured single-threaded in alternation (a, b, a, b, ...: cfg.repeat
// rounds; a solver whose run exceeds cfg.budget is not run again), so that a slow
// phase of a shared machine (another process's burst on the sibling hyperthread)
// falls on both rather than on all runs of one. Same figures as measure_solve.
std::pair<Measured, Measured> measure_alternating(Solver& a, Solver& b, const Scene& scene, const SolveOptions& base,
                                                  const MeasureConfig& cfg);

// Paired rounds of two solvers on their own scenes (a on sa, b on sb: e.g. embree at
// the sample count of equal quality and an exact method), single-threaded, a then b in
// each of `rounds` rounds, one run each: per-round seconds (SolveResult::seconds, else
// wall) and process CPU seconds, in round order. A slow phase of a shared machine then
// falls on both methods' runs of a round instead of on all runs of one. The rounds stop
// after one in which either run exceeded cfg.budget.
struct PairedTimes {
  std::vector<double> a_seconds, b_seconds, a_cpu, b_cpu;
};
PairedTimes measure_paired(Solver& a, const Scene& sa, const SolveOptions& oa, Solver& b, const Scene& sb,
                           const SolveOptions& ob, int rounds, const MeasureConfig& cfg);

// Ratios of paired runs: x[r] and base[r] measured in the same round r (seconds
// apart), as the interleaved doubling rounds of the iss-target experiment make them.
// of_minima = min(x) / min(base); median, lo and hi over the per-round ratios x[r] /
// base[r]. NaN everywhere when the series are empty or of different lengths.
struct RoundRatios {
  double of_minima, median, lo, hi;
};
RoundRatios round_ratios(const std::vector<double>& base, const std::vector<double>& x);

// Times any callable the same way (min over `repeat` runs) and records its peak.
struct Timed {
  double seconds = std::numeric_limits<double>::quiet_NaN();
  double peak_mb = 0.0;
  int runs = 0;
};
template <class F>
Timed time_min(int repeat, double budget, F&& fn) {
  Timed t;
  for (int r = 0; r < std::max(1, repeat); ++r) {
    bool reset = reset_peak_memory();
    double before = rss_mb();
    auto t0 = std::chrono::steady_clock::now();
    fn();
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    double peak = reset ? hwm_mb() - before : hwm_mb();
    t.peak_mb = std::max(t.peak_mb, peak);
    t.seconds = t.runs ? std::min(t.seconds, s) : s;
    ++t.runs;
    if (s > budget) break;
  }
  return t;
}

// Skips the next, larger point of a sweep for a method when its predicted time (the
// last measured time scaled linearly with the size) exceeds the budget.
class SweepGuard {
 public:
  explicit SweepGuard(double budget) : budget_(budget) {}
  // True (and `why` set) when `method` at `size` is predicted to exceed the budget.
  bool skip(const std::string& method, double size, std::string* why) const;
  void record(const std::string& method, double size, double seconds) { last_[method] = {size, seconds}; }

 private:
  double budget_;
  std::map<std::string, std::pair<double, double>> last_;
};

}  // namespace visgate::bench
