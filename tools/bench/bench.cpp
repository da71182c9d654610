// What every `visgate bench` experiment shares: options, progress, notes, the method
// and family lists, scene generation (see bench.h).
#include "tools/bench/bench.h"

#include "lib/base/memory_budget.h"
#include "lib/external/external_methods.h"
#include "tools/bench/run_method.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace visgate::bench {

namespace {
double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

Progress::Progress(bool enabled, std::string experiment)
    : enabled_(enabled), experiment_(std::move(experiment)), start_(now_seconds()) {}

void Progress::step(const std::string& what) {
  if (!enabled_) return;
  std::fprintf(stderr, "\r\033[K[%s] %zu done, %.1f s: %s", experiment_.c_str(), count_++, now_seconds() - start_,
               what.c_str());
  std::fflush(stderr);
  dirty_ = true;
}

void Progress::done() {
  if (!enabled_ || !dirty_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  dirty_ = false;
}

BenchContext::BenchContext(const BenchOptions& o) : opt(o), progress(o.progress && !o.quiet, o.experiment) {
  report.experiment = o.experiment;
}

void BenchContext::note(const std::string& text) {
  for (const auto& n : noted_)
    if (n == text) return;
  noted_.push_back(text);
  report.notes.push_back(text);
  if (!opt.quiet) {
    progress.done();
    std::fprintf(stderr, "visgate bench %s: %s\n", opt.experiment.c_str(), text.c_str());
  }
}

std::vector<std::string> BenchContext::methods() {
  std::vector<std::string> reg = solver_names(), out;
  if (opt.methods.empty()) return reg;
  for (const auto& m : opt.methods) {
    bool found = false;
    for (const auto& r : reg) found |= (r == m);
    found |= external::is_external_method(m);  // exec:CMD, plugin:PATH
    if (found) out.push_back(m);
    else note("method " + m + " is not registered in this build: skipped");
  }
  return out;
}

std::vector<std::string> BenchContext::families(const std::vector<std::string>& wanted) {
  std::vector<std::string> out;
  for (const auto& f : wanted) {
    if (!opt.families.empty()) {
      bool requested = false;
      for (const auto& r : opt.families) requested |= (r == f);
      if (!requested) continue;
    }
    if (is_family(f)) out.push_back(f);
    else note("family " + f + " is not registered in this build: skipped");
  }
  for (const auto& r : opt.families) {
    bool listed = false;
    for (const auto& f : wanted) listed |= (r == f);
    if (!listed) note("family " + r + " is not used by this experiment: ignored");
  }
  return out;
}

bool BenchContext::has_method(const std::string& method, const std::string& what) {
  for (const auto& r : solver_names())
    if (r == method) return true;
  if (external::is_external_method(method)) return true;
  note(method + " is not registered in this build: " + what + " skipped");
  return false;
}

std::unique_ptr<Solver> BenchContext::solver(const std::string& method) {
  auto s = make_solver(method);
  if (!s) note(method + " is not registered in this build: skipped");
  return s;
}

MeasureConfig BenchContext::measure_config() const {
  MeasureConfig c;
  c.repeat = opt.repeat;
  c.all_threads = opt.threads;
  c.budget = opt.budget;
  return c;
}

Result<Scene> BenchContext::scene(const std::string& family, const FamilyParams& p) {
  auto s = generate_family(family, p);
  if (!s) return Error{"family " + family + " (seed " + std::to_string(p.seed) + "): " + s.error().message};
  return s;
}

Json scene_summary(const Scene& s) {
  return {{"name", s.name},
          {"triangles", s.mesh.size()},
          {"lights", s.lights.size()},
          {"receivers", s.receivers.size()},
          {"samples_per_receiver", s.samples_per_receiver()},
          {"relations", s.relation_count()}};
}

double stat_or_nan(const Stats& s, const std::vector<std::string>& keys) {
  for (const auto& k : keys) {
    if (const Stats::Entry* e = s.find(k)) return e->second;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::optional<SolveOptions> checked_options(BenchContext& ctx, const Solver& solver, const std::string& method,
                                            const std::map<std::string, std::string>& opts, const std::string& label) {
  SolveOptions so;
  so.seed = ctx.opt.seed;
  so.opts = opts;
  so.memory_budget_mb = ctx.opt.memory_budget_mb;
  Status st = solver.check_options(so);
  if (!st) {
    ctx.note(method + " at " + label + ": " + st.error().message + ": skipped");
    return std::nullopt;
  }
  return so;
}

std::optional<Measured> run_method(BenchContext& ctx, const std::string& method, const Scene& scene,
                                   const std::string& label, SweepGuard* guard, double size,
                                   const std::map<std::string, std::string>& opts, const MeasureConfig* config) {
  std::string why;
  if (guard && guard->skip(method, size, &why)) {
    ctx.note(method + " skipped at " + label + ": " + why);
    return std::nullopt;
  }
  auto solver = make_solver(method);
  if (!solver) {
    ctx.note(method + " is not registered in this build: skipped");
    return std::nullopt;
  }
  auto so = checked_options(ctx, *solver, method, opts, label);
  if (!so) return std::nullopt;
  ctx.progress.step(method + " " + label);
  Measured m;
  try {
    m = measure_solve(*solver, scene, *so, config ? *config : ctx.measure_config());
  } catch (const MemoryBudgetExceeded& e) {
    ctx.note(method + " at " + label + ": " + e.what() + ": skipped");
    return std::nullopt;
  }
  if (guard) guard->record(method, size, m.seconds());
  return m;
}

double blocked_share(const Scene& scene, const SolveResult& r) {
  size_t rel = scene.relation_count(), vis = 0;
  if (!rel) return 0.0;
  for (const auto& rr : r.receivers)
    for (uint64_t w : rr.visible_bits) vis += size_t(__builtin_popcountll(w));
  return 1.0 - double(vis) / double(rel);
}

void add_stat_rows(Table& t, const std::vector<Json>& prefix, const Stats& stats) {
  for (const auto& [k, v] : stats.sorted()) {
    std::vector<Json> row = prefix;
    row.push_back(std::string(k));
    row.push_back(v);
    t.add_row(std::move(row));
  }
}

double ratio(double a, double b) {
  if (!std::isfinite(a) || !std::isfinite(b) || b == 0) return std::numeric_limits<double>::quiet_NaN();
  return a / b;
}

}  // namespace visgate::bench
