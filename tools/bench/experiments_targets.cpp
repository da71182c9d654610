// `visgate bench targets` (docs/bench.md, where the table of targets is): the speed
// targets at their own sizes, each a row with a threshold and a verdict. Every row is
// single-threaded: the method and embree alternate on the same scene (embree at the
// equal-quality sample count for plucker-bsp) for max(3, --repeat) rounds, so a slow
// phase of a shared machine falls on both; the ratio is embree's minimum over the
// method's, and its spread the lowest and highest of the per-round ratios. The scan rows
// run with a memory budget of 1 GB (the target's ceiling) and add a growth row per
// method: its time at 300k triangles over its time at 75k.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lib/base/memory_budget.h"
#include "tools/bench/bench.h"
#include "tools/bench/run_method.h"

namespace visgate::bench {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kEqualQuality = 0.005;  // penumbra RMS of embree against the exact fractions
constexpr uint64_t kScanMemoryMb = 1024;

struct Target {
  std::string name, method, family;
  long triangles = -1, receivers = -1, samples = -1;  // -1: the family's default
  bool equal_quality = false;  // embree at the smallest N reaching kEqualQuality
  double min_ratio = 1.0;
  double max_ray_pct = kNaN;  // NaN: no ray-cast ceiling
  bool scan = false;          // 1 GB memory ceiling, growth rows
};

// The rows. --quick keeps each row's shape at smoke sizes (seconds in all).
std::vector<Target> targets(bool quick) {
  auto q = [quick](long full, long small) { return quick ? small : full; };
  std::vector<Target> t = {
      {"iss columns 1024x768 x 256", "iss", "columns", -1, q(1024 * 768, 48 * 48), 256, false, 2.5, 50.0},
      {"iss rooms 1024 x 1728", "iss", "rooms", q(-1, 7000), 1024, 64, false, 10.0, 2.0},
      {"iss rooms 473k", "iss", "rooms", q(500000, 30000), q(65536, 1024), 64, false, 10.0},
      {"ssv columns x 256", "ssv", "columns", -1, q(-1, 32 * 32), 256, false, 5.0},
      {"ssv rooms", "ssv", "rooms", q(-1, 7000), q(-1, 256), q(-1, 16), false, 1.0},
      {"ssv foliage", "ssv", "foliage", q(-1, 3000), q(-1, 256), q(-1, 64), false, 1.0},
      {"plucker-bsp columns, equal quality", "plucker-bsp", "columns", -1, q(64 * 64, 16 * 16), 16, true, 5.0},
      {"plucker-bsp rooms, equal quality", "plucker-bsp", "rooms", q(-1, 7000), q(32 * 32, 16 * 16), 16, true, 10.0},
  };
  for (long tri : {q(75000, 2000), q(300000, 8000)}) {
    const std::string size = std::to_string(tri / 1000) + "k";
    for (const char* m : {"iss", "ssv"})
      t.push_back({std::string(m) + " scan " + size + " x 64", m, "scan", tri, q(1024, 64), q(64, 8), false, 1.0,
                   kNaN, true});
    t.push_back({"plucker-bsp scan " + size + ", equal quality", "plucker-bsp", "scan", tri, q(1024, 64), 16, true,
                 1.0, kNaN, true});
  }
  return t;
}

class TargetRunner {
 public:
  explicit TargetRunner(BenchContext& ctx) : ctx_(ctx) {}

  Table rows{"targets",
             "each target single-threaded against embree in alternating rounds on the same scene: ratio = embree's "
             "minimum / the method's minimum, ratio_lo/ratio_hi the extremes of the per-round ratios; pass when the "
             "ratio, the ray-cast share and (scan) the peak memory meet the target",
             {"target", "method", "family", "triangles", "lights", "receivers", "samples_per_receiver", "relations_M",
              "embree_samples_per_light", "embree_penumbra_rms", "ray_cast_pct", "seconds_min", "embree_seconds_min",
              "rounds", "ratio", "ratio_median", "ratio_lo", "ratio_hi", "ratio_cpu", "peak_mb", "min_ratio",
              "max_ray_cast_pct", "max_peak_mb", "pass", "why"},
             {}};
  Table growth{"growth",
               "scan: each method's minimum time at the larger scan over the smaller, same receivers and samples; "
               "pass below 2",
               {"method", "triangles_small", "triangles_large", "seconds_small", "seconds_large", "growth", "pass"},
               {}};
  int failed = 0;

  void run(const Target& t) {
    if (!ctx_.has_method(t.method, "the target " + t.name) || !ctx_.has_method("embree", "the targets")) return;
    const auto& only = ctx_.opt.families;
    if (!only.empty() && std::find(only.begin(), only.end(), t.family) == only.end()) return;
    // --methods picks the rows' methods; embree runs beside each row whatever it says.
    const auto& picked = ctx_.opt.methods;
    if (!picked.empty() && std::find(picked.begin(), picked.end(), t.method) == picked.end()) return;
    FamilyParams p;
    p.seed = ctx_.opt.seed;
    p.triangles = t.triangles;
    p.receivers = t.receivers;
    p.samples = t.samples;
    auto scene = ctx_.scene(t.family, p);
    if (!scene) return fail_row(t, nullptr, scene.error().message);
    const Scene& s = *scene;
    auto method = ctx_.solver(t.method), emb = ctx_.solver("embree");
    auto checked = checked_options(ctx_, *method, t.method, {}, t.name);
    if (!checked) return fail_row(t, &s, "the method refused its default options");
    SolveOptions so = *checked;
    if (t.scan)  // the target's ceiling, or a lower --memory-budget
      so.memory_budget_mb = std::min<uint64_t>(so.memory_budget_mb ? so.memory_budget_mb : kScanMemoryMb, kScanMemoryMb);
    // A scan row at 300k is predicted from its 75k row (time linear in triangles, the
    // worst the target allows for), and not run past --budget.
    if (t.scan) {
      auto it = scan_seconds_.find(t.method);
      if (it != scan_seconds_.end() && it->second.second * double(s.mesh.size()) / it->second.first > ctx_.opt.budget)
        return fail_row(t, &s, "not run: predicted " + fmt(it->second.second * double(s.mesh.size()) / it->second.first) +
                                   " s per run from the smaller scan, over the budget of " + fmt(ctx_.opt.budget) +
                                   " s (--budget raises it)");
    }
    const MeasureConfig one = single_run(ctx_.measure_config());
    ctx_.progress.step(t.name + ": " + t.method);
    Measured first;
    try {
      first = measure_solve(*method, s, so, one);
    } catch (const MemoryBudgetExceeded& e) {
      return fail_row(t, &s, e.what());
    }
    // The embree side: the same scene, or for equal quality the smallest N whose penumbra
    // RMS against the method's exact fractions is at most kEqualQuality.
    std::optional<Scene> eq_scene;
    long emb_n = long(s.lights.front().samples);
    double emb_rms = kNaN;
    if (t.equal_quality) {
      const std::vector<double> exact = method_fractions(s, first.result);
      for (long n = 16; n <= 4096 && !eq_scene; n *= 2) {
        FamilyParams pn = p;
        pn.samples = n;
        auto sn = ctx_.scene(t.family, pn);
        if (!sn) return fail_row(t, &s, sn.error().message);
        ctx_.progress.step(t.name + ": embree N=" + std::to_string(n));
        Measured m = measure_solve(*emb, *sn, so, one);
        const double rms = penumbra_rms(method_fractions(*sn, m.result), exact, nullptr);
        if (rms <= kEqualQuality || std::isnan(rms)) {
          eq_scene = std::move(*sn);
          emb_n = n;
          emb_rms = rms;
        } else if (m.seconds_1t > ctx_.opt.budget) {
          break;
        }
      }
      if (!eq_scene) return fail_row(t, &s, "embree reached no penumbra RMS <= 0.5% at N <= 4096 within the budget");
    }
    const Scene& es = eq_scene ? *eq_scene : s;
    const int rounds = std::max(3, ctx_.opt.repeat);
    ctx_.progress.step(t.name + ": " + std::to_string(rounds) + " rounds with embree");
    PairedTimes pt;
    try {
      pt = measure_paired(*method, s, so, *emb, es, so, rounds, ctx_.measure_config());
    } catch (const MemoryBudgetExceeded& e) {
      return fail_row(t, &s, e.what());
    }
    const RoundRatios rr = round_ratios(pt.a_seconds, pt.b_seconds), rc = round_ratios(pt.a_cpu, pt.b_cpu);
    const double sec = std::min(first.seconds_1t, *std::min_element(pt.a_seconds.begin(), pt.a_seconds.end()));
    const double esec = *std::min_element(pt.b_seconds.begin(), pt.b_seconds.end());
    const double rel = double(s.relation_count());
    double ray = kNaN, decided = kNaN;
    if (!t.equal_quality) ray_cast_shares(t.method, first.stats, rel, ray, decided);
    const double max_peak = t.scan ? double(kScanMemoryMb) : kNaN;
    // The run's own growth of the process can miss memory a method reuses from earlier
    // runs' freed heap; the method's count of its structures (the memory budget's) cannot.
    const double own = method_peak_mb(first.stats);
    const double peak = std::isnan(own) ? first.peak_mb : std::max(first.peak_mb, own);
    std::string why;
    if (!(rr.of_minima >= t.min_ratio)) why += "ratio " + fmt(rr.of_minima) + " < " + fmt(t.min_ratio) + "; ";
    if (!std::isnan(t.max_ray_pct) && !(ray <= t.max_ray_pct))
      why += "ray-cast " + fmt(ray) + "% > " + fmt(t.max_ray_pct) + "%; ";
    if (t.scan && peak > max_peak) why += "peak " + fmt(peak) + " MB > 1024 MB; ";
    const bool pass = why.empty();
    if (!pass) ++failed, why.resize(why.size() - 2);
    rows.add_row({t.name, t.method, t.family, s.mesh.size(), s.lights.size(), s.receivers.size(),
                  s.samples_per_receiver(), rel / 1e6, emb_n, emb_rms, ray, sec, esec, int(pt.a_seconds.size()),
                  rr.of_minima, rr.median, rr.lo, rr.hi, rc.of_minima, peak, t.min_ratio, t.max_ray_pct,
                  max_peak, pass, why});
    if (t.scan) {
      auto it = scan_seconds_.find(t.method);
      const std::pair<double, double> here{double(s.mesh.size()), sec}, emb_here{double(s.mesh.size()), esec};
      if (it == scan_seconds_.end()) {
        scan_seconds_[t.method] = here;
        if (t.method == "iss") embree_small_ = emb_here;
      } else {
        add_growth(t.method, it->second, here);
        if (t.method == "iss" && embree_small_) add_growth("embree", *embree_small_, emb_here);
      }
    }
    if (!ctx_.opt.quiet) {
      ctx_.progress.done();
      std::fprintf(stderr, "visgate bench targets: %s: %s %.3f s, embree%s %.3f s, ratio %.2f (rounds %.2f-%.2f), target %s %s%s%s\n",
                   t.name.c_str(), t.method.c_str(), sec,
                   t.equal_quality ? (" N=" + std::to_string(emb_n)).c_str() : "", esec, rr.of_minima, rr.lo, rr.hi,
                   fmt(t.min_ratio).c_str(), pass ? "PASS" : "FAIL", pass ? "" : ": ", why.c_str());
    }
  }

  void finish() {
    ctx_.report.options["equal_quality_penumbra_rms"] = kEqualQuality;
    ctx_.report.options["scan_memory_budget_mb"] = kScanMemoryMb;
    ctx_.report.options["rounds"] = std::max(3, ctx_.opt.repeat);
    ctx_.report.options["targets_failed"] = failed;
    ctx_.report.tables.push_back(std::move(rows));
    ctx_.report.tables.push_back(std::move(growth));
    ctx_.note(failed ? std::to_string(failed) + " target row(s) failed" : "every target row passed");
  }

 private:
  static std::string fmt(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
  }

  void fail_row(const Target& t, const Scene* s, const std::string& why) {
    ++failed;
    rows.add_row({t.name, t.method, t.family, s ? Json(s->mesh.size()) : Json(kNaN),
                  s ? Json(s->lights.size()) : Json(kNaN), s ? Json(s->receivers.size()) : Json(kNaN),
                  s ? Json(s->samples_per_receiver()) : Json(kNaN),
                  s ? Json(double(s->relation_count()) / 1e6) : Json(kNaN), kNaN, kNaN, kNaN, kNaN, kNaN, 0, kNaN,
                  kNaN, kNaN, kNaN, kNaN, kNaN, t.min_ratio, t.max_ray_pct, t.scan ? double(kScanMemoryMb) : kNaN,
                  false, why});
    ctx_.note("target " + t.name + ": FAIL: " + why);
  }

  void add_growth(const std::string& method, std::pair<double, double> small, std::pair<double, double> large) {
    const double g = large.second / small.second;
    growth.add_row({method, small.first, large.first, small.second, large.second, g, g < 2.0});
    if (method != "embree" && !(g < 2.0)) ++failed;
    ctx_.note("growth " + method + " scan " + fmt(small.first) + " -> " + fmt(large.first) + " triangles: x" + fmt(g) +
              (g < 2.0 ? "" : (method == "embree" ? " (reference)" : " FAIL")));
  }

  BenchContext& ctx_;
  std::map<std::string, std::pair<double, double>> scan_seconds_;  // method -> (triangles, s) of the small scan
  std::optional<std::pair<double, double>> embree_small_;  // embree beside iss on the small scan
};

Status run_targets(BenchContext& ctx) {
  TargetRunner tr(ctx);
  for (Target t : targets(ctx.opt.quick)) {
    if (ctx.opt.quick) t.name += " (quick)";  // the names give the full sizes
    tr.run(t);
  }
  tr.finish();
  return {};
}

}  // namespace

void add_target_experiment(std::vector<Experiment>& out) {
  out.push_back({"targets", "the speed targets at their sizes, each against embree in the same run, with a verdict",
                 run_targets});
}

}  // namespace visgate::bench
