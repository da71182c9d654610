// Measuring methods: repeated runs, per-run peak memory (see measure.h).
#include "tools/bench/measure.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>
#include <vector>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

namespace visgate::bench {

namespace {

double status_mb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  size_t n = std::char_traits<char>::length(key);
  while (std::getline(in, line))
    if (line.compare(0, n, key) == 0 && line.size() > n && line[n] == ':') {
      try {
        return double(std::stol(line.substr(n + 1))) / 1024.0;  // kB
      } catch (...) {
        return 0.0;
      }
    }
  return 0.0;
}

}  // namespace

bool reset_peak_memory() {
  std::FILE* f = std::fopen("/proc/self/clear_refs", "w");
  if (!f) return false;
  bool ok = std::fputs("5", f) >= 0;
  ok = (std::fclose(f) == 0) && ok;
  return ok;
}

const char* peak_memory_mode() {
  static const bool per_run = reset_peak_memory();
  return per_run ? "per-run" : "process-hwm";
}

double rss_mb() { return status_mb("VmRSS"); }
double hwm_mb() { return status_mb("VmHWM"); }

namespace {
double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
}  // namespace

Measured measure_solve(Solver& solver, const Scene& scene, const SolveOptions& base, const MeasureConfig& cfg) {
  Measured m;
  int all_threads = cfg.all_threads > 0 ? cfg.all_threads : int(std::max(1u, std::thread::hardware_concurrency()));
  auto one_setting = [&](int threads, double& best, int& runs) {
    SolveOptions so = base;
    so.threads = threads;
    for (int r = 0; r < std::max(1, cfg.repeat); ++r) {
      bool reset = reset_peak_memory();
      double before = rss_mb();
      auto t0 = std::chrono::steady_clock::now();
      double c0 = process_cpu_seconds();
      SolveResult res = solver.solve(scene, so);
      double cpu = process_cpu_seconds() - c0;
      double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (threads == 1) m.cpu_1t = std::isnan(m.cpu_1t) ? cpu : std::min(m.cpu_1t, cpu);
      double peak = reset ? hwm_mb() - before : hwm_mb();
      m.peak_mb = std::max(m.peak_mb, peak);
      double s = res.seconds > 0 ? res.seconds : wall;
      best = runs ? std::min(best, s) : s;
      ++runs;
      if (m.result.receivers.empty()) {
        m.stats = res.stats;
        m.result = std::move(res);
      }
      if (s > cfg.budget) break;  // a long run is not repeated
    }
  };
  if (cfg.single) one_setting(1, m.seconds_1t, m.runs_1t);
  // A single-threaded run beyond the budget is not repeated with all threads either.
  bool over = m.runs_1t && m.seconds_1t > cfg.budget;
  if (cfg.all && !over) one_setting(all_threads, m.seconds_all, m.runs_all);
  return m;
}

MeasureConfig single_run(MeasureConfig cfg) {
  cfg.repeat = 1;
  cfg.single = true;
  cfg.all = false;
  return cfg;
}

std::pair<Measured, Measured> measure_alternating(Solver& a, Solver& b, const Scene& scene, const SolveOptions& base,
                                                  const MeasureConfig& cfg) {
  const MeasureConfig one = single_run(cfg);
  std::pair<Measured, Measured> out;
  auto merge = [](Measured& into, Measured&& run) {
    if (into.runs_1t == 0) {
      into = std::move(run);
      return;
    }
    into.seconds_1t = std::min(into.seconds_1t, run.seconds_1t);
    into.cpu_1t = std::min(into.cpu_1t, run.cpu_1t);
    into.peak_mb = std::max(into.peak_mb, run.peak_mb);
    into.runs_1t += run.runs_1t;
  };
  bool more_a = true, more_b = true;
  for (int r = 0; r < std::max(1, cfg.repeat) && (more_a || more_b); ++r) {
    if (more_a) {
      merge(out.first, measure_solve(a, scene, base, one));
      more_a = out.first.seconds_1t <= cfg.budget;
    }
    if (more_b) {
      merge(out.second, measure_solve(b, scene, base, one));
      more_b = out.second.seconds_1t <= cfg.budget;
    }
  }
  return out;
}

PairedTimes measure_paired(Solver& a, const Scene& sa, const SolveOptions& oa, Solver& b, const Scene& sb,
                           const SolveOptions& ob, int rounds, const MeasureConfig& cfg) {
  const MeasureConfig one = single_run(cfg);
  PairedTimes t;
  for (int r = 0; r < rounds; ++r) {
    Measured ma = measure_solve(a, sa, oa, one);
    Measured mb = measure_solve(b, sb, ob, one);
    t.a_seconds.push_back(ma.seconds_1t);
    t.b_seconds.push_back(mb.seconds_1t);
    t.a_cpu.push_back(ma.cpu_1t);
    t.b_cpu.push_back(mb.cpu_1t);
    if (ma.seconds_1t > cfg.budget || mb.seconds_1t > cfg.budget) break;  // long runs are not repeated
  }
  return t;
}

RoundRatios round_ratios(const std::vector<double>& base, const std::vector<double>& x) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  if (base.empty() || base.size() != x.size()) return {nan, nan, nan, nan};
  std::vector<double> r(x.size());
  for (size_t k = 0; k < x.size(); ++k) r[k] = x[k] / base[k];
  std::sort(r.begin(), r.end());
  const size_t h = r.size() / 2;
  const double med = r.size() % 2 ? r[h] : 0.5 * (r[h - 1] + r[h]);
  return {*std::min_element(x.begin(), x.end()) / *std::min_element(base.begin(), base.end()), med, r.front(),
          r.back()};
}

bool SweepGuard::skip(const std::string& method, double size, std::string* why) const {
  auto it = last_.find(method);
  if (it == last_.end() || it->second.first <= 0) return false;
  double predicted = it->second.second * size / it->second.first;
  if (predicted <= budget_) return false;
  if (why) {
    char b[160];
    std::snprintf(b, sizeof b, "predicted %.1f s per run (last %.2f s at %g, linear) exceeds the budget %.0f s",
                  predicted, it->second.second, it->second.first, budget_);
    *why = b;
  }
  return true;
}

}  // namespace visgate::bench
