// The paper-scale experiments of `visgate bench` (docs/bench.md):
//   iss-paper      paper 000 Tables 5.2/5.3 at the thesis's sizes: columns and foliage at
//                  512x384, 1024x768 and 2048x1536 receivers with the thesis's samples,
//                  4x samples and 4x light area; rooms at three sizes up to 2M triangles;
//   ssv-paper      paper 001 Table 1's settings (960x540 receivers, 256 samples);
//   plucker-paper  paper 002 Figure 7 at equal quality (embree at the smallest N whose
//                  penumbra RMS against plucker-bsp's exact fractions is at most 0.5%);
//   scan           the scan family at 75k and 300k triangles: iss, ssv, plucker-bsp, embree.
// Every row is single-threaded: seconds are the minimum of the runs and their spread,
// embree measured in the same run on the same scene. Rows are long (minutes at full
// size), so each method's time on a row is predicted before it runs (linearly in
// relations from its previous row of the same group, else from probes on 1/64 and 1/16 of the
// receivers) and a row predicted past --budget, or past what is left of the
// experiment's 28-minute allowance, is skipped with a note; --budget also stops the
// repeats (no further run once the runs' sum would pass it).
#include <algorithm>
#include <chrono>
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
constexpr double kAllowanceSeconds = 28 * 60;  // the whole experiment, full size
constexpr double kProbeAbove = 1e5;            // relations: smaller rows run unpredicted

double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// One scene of an experiment: `group` rows share predictions (a size sweep of a family).
struct PaperScene {
  std::string group, config, family;
  FamilyParams params;
};

struct Timing {
  double min = kNaN, max = kNaN, peak_mb = 0.0;
  double cpu_min = kNaN;  // process CPU seconds of the whole solve() call (measure.h), min over the runs
  int runs = 0;
  Stats stats;
  SolveResult result;
};

class PaperRunner {
 public:
  explicit PaperRunner(BenchContext& ctx) : ctx_(ctx), start_(now_s()) {
    ctx.report.options["single_threaded"] = true;
    ctx.report.options["allowance_seconds"] = ctx.opt.quick ? 0.0 : kAllowanceSeconds;
    ctx.report.options["prediction"] =
        "linear in relations from the method's previous row of the group, else from a probe on 1/64 of the receivers (and 1/16 when the first predicts past the budget)";
  }

  Table rows{"rows",
             "every method single-threaded against embree in the same run: seconds the minimum of the runs, spread "
             "(max - min) / min; ratio embree / method; ray_cast_pct relations answered by rays (iss: leaf and "
             "automatic rays; ssv: fallback relations; plucker-bsp: segment relations), decided_pct by the method's "
             "own structure",
             {"group", "config", "method", "triangles", "lights", "receivers", "samples_per_receiver", "relations_M",
              "ray_cast_pct", "decided_pct", "seconds_min", "seconds_max", "spread_pct", "runs", "peak_mb",
              "method_peak_mb", "embree_samples_per_light", "embree_seconds_min", "embree_spread_pct", "ratio",
              "penumbra_rms", "cpu_seconds_min", "embree_cpu_seconds_min", "ratio_cpu"},
             {}};
  Table stats{"stats", "every figure each method reports, per row", {"group", "config", "method", "stat", "value"}, {}};

  // Measures `method` on `s` (the scene of `ps`), or notes why not: not registered,
  // predicted past the budget or the allowance, past the memory budget.
  std::optional<Timing> measure(const std::string& method, const PaperScene& ps, const Scene& s,
                                const std::map<std::string, std::string>& opts = {}) {
    const std::string label = ps.group + " " + ps.config;
    if (!ctx_.has_method(method, "its " + ctx_.opt.experiment + " rows")) return std::nullopt;
    const double rel = double(s.relation_count());
    double predicted = 0.0;
    auto it = last_.find({ps.group, method});
    if (it != last_.end()) {
      predicted = it->second.second * rel / it->second.first;
    } else if (rel > kProbeAbove && !ctx_.opt.quick) {
      auto p1 = probe(method, ps, opts, std::max(16L, long(s.receivers.size()) / 64), label);
      if (!p1) return std::nullopt;
      predicted = p1->second * rel / p1->first;
      // Per-light set-up (wedges, trees) makes one probe overestimate: a second on four
      // times the receivers, when it fits the budget, fits time = a + b x relations.
      if (predicted > ctx_.opt.budget && 4 * p1->second <= ctx_.opt.budget && 4 * p1->first < rel) {
        auto p2 = probe(method, ps, opts, 4 * std::max(16L, long(s.receivers.size()) / 64), label);
        if (!p2) return std::nullopt;
        const double b = (p2->second - p1->second) / (p2->first - p1->first);
        predicted = b > 0 ? std::max(p2->second, p2->second + b * (rel - p2->first)) : p2->second;
      }
    }
    const double left = kAllowanceSeconds - (now_s() - start_);
    if (predicted > ctx_.opt.budget || (!ctx_.opt.quick && predicted > left)) {
      ctx_.note(method + " skipped at " + label + ": predicted " + fmt("%.0f", predicted) + " s per run exceeds " +
                (predicted > ctx_.opt.budget ? "the budget " + fmt("%.0f", ctx_.opt.budget) + " s (--budget raises it)"
                                             : "the " + fmt("%.0f", left) + " s left of the experiment's allowance"));
      return std::nullopt;
    }
    ctx_.progress.step(method + " " + label);
    auto t = run(method, s, opts, ctx_.opt.repeat, label);
    if (t) last_[{ps.group, method}] = {rel, t->min};
    return t;
  }

  // One row of the table (and its stats); `embree` the reference of the row.
  void add(const PaperScene& ps, const Scene& s, const std::string& method, const std::optional<Timing>& t,
           const std::optional<Timing>& embree, long embree_samples, double penumbra = kNaN) {
    if (!t) return;
    const double rel = double(s.relation_count());
    double ray = kNaN, decided = kNaN;
    ray_cast_shares(method, t->stats, rel, ray, decided);
    const double e = embree ? embree->min : kNaN;
    rows.add_row({ps.group, ps.config, method, s.mesh.size(), s.lights.size(), s.receivers.size(),
                  s.samples_per_receiver(), rel / 1e6, ray, decided, t->min, t->max,
                  100.0 * (t->max - t->min) / t->min, t->runs, t->peak_mb, method_peak_mb(t->stats), embree_samples, e,
                  embree ? 100.0 * (embree->max - embree->min) / embree->min : kNaN, ratio(e, t->min), penumbra,
                  t->cpu_min, embree ? embree->cpu_min : kNaN, ratio(embree ? embree->cpu_min : kNaN, t->cpu_min)});
    add_stat_rows(stats, {ps.group, ps.config, method}, t->stats);
    if (!ctx_.opt.quiet) {
      ctx_.progress.done();
      std::fprintf(stderr, "visgate bench %s: %s %s: %s %.3f s (%d runs, spread %.0f%%), %.1f%% ray-cast, %.0f MB",
                   ctx_.opt.experiment.c_str(), ps.group.c_str(), ps.config.c_str(), method.c_str(), t->min, t->runs,
                   100.0 * (t->max - t->min) / t->min, ray, t->peak_mb);
      if (method != "embree") std::fprintf(stderr, ", embree %.3f s, ratio %.2f", e, ratio(e, t->min));
      std::fprintf(stderr, "\n");
    }
  }

  void finish() {
    ctx_.report.tables.push_back(std::move(rows));
    ctx_.report.tables.push_back(std::move(stats));
  }

  BenchContext& ctx() { return ctx_; }

 private:
  // One run on the scene of `ps` with `receivers` receivers: (relations, seconds).
  std::optional<std::pair<double, double>> probe(const std::string& method, const PaperScene& ps,
                                                 const std::map<std::string, std::string>& opts, long receivers,
                                                 const std::string& label) {
    FamilyParams q = ps.params;
    q.receivers = receivers;
    auto s = ctx_.scene(ps.family, q);
    if (!s) return std::nullopt;
    ctx_.progress.step(method + " " + label + " (probe, " + std::to_string(s->receivers.size()) + " receivers)");
    auto t = run(method, *s, opts, 1, label + " (probe)");
    if (!t) return std::nullopt;
    return std::make_pair(double(s->relation_count()), t->min);
  }

  // Up to `repeat` single-threaded runs; no further run once the runs' sum would pass
  // the budget. nullopt (noted) past the memory budget or for rejected options.
  std::optional<Timing> run(const std::string& method, const Scene& s, const std::map<std::string, std::string>& opts,
                            int repeat, const std::string& label) {
    auto solver = make_solver(method);
    if (!solver) return std::nullopt;
    auto checked = checked_options(ctx_, *solver, method, opts, label);
    if (!checked) return std::nullopt;
    const SolveOptions& so = *checked;
    Timing t;
    double spent = 0.0;
    try {
      for (int r = 0; r < std::max(1, repeat); ++r) {
        Measured m = measure_solve(*solver, s, so, single_run(ctx_.measure_config()));
        const double sec = m.seconds_1t;
        t.min = r ? std::min(t.min, sec) : sec;
        t.max = r ? std::max(t.max, sec) : sec;
        t.peak_mb = std::max(t.peak_mb, m.peak_mb);
        t.cpu_min = r ? std::min(t.cpu_min, m.cpu_1t) : m.cpu_1t;
        ++t.runs;
        if (r == 0) {
          t.stats = m.stats;
          t.result = std::move(m.result);
        }
        spent += sec;
        if (spent + sec > ctx_.opt.budget) break;
      }
    } catch (const MemoryBudgetExceeded& e) {
      ctx_.note(method + " at " + label + " on " + s.name + ": " + e.what() + ": skipped");
      return std::nullopt;
    }
    return t;
  }

  BenchContext& ctx_;
  double start_;
  std::map<std::pair<std::string, std::string>, std::pair<double, double>> last_;  // (group, method) -> (relations, s)
};

// A scene of the experiment; none for a family left out by --families, or (noted) not
// registered or refused.
std::optional<Scene> make_scene(BenchContext& ctx, const PaperScene& ps) {
  const auto& only = ctx.opt.families;
  if (!only.empty() && std::find(only.begin(), only.end(), ps.family) == only.end()) return std::nullopt;
  if (!is_family(ps.family)) {
    ctx.note("family " + ps.family + " is not registered in this build: " + ps.group + " skipped");
    return std::nullopt;
  }
  auto s = ctx.scene(ps.family, ps.params);
  if (!s) {
    ctx.note(s.error().message + ": skipped");
    return std::nullopt;
  }
  return std::move(*s);
}

PaperScene paper_scene(const BenchOptions& o, std::string group, std::string config, std::string family, long triangles,
                       long receivers, long samples, double light_scale = 1.0) {
  PaperScene ps{std::move(group), std::move(config), std::move(family), {}};
  ps.params.seed = o.seed;
  ps.params.triangles = triangles;
  ps.params.receivers = receivers;
  ps.params.samples = samples;
  ps.params.light_scale = light_scale;
  return ps;
}

// Rows measured by embree then by each of `methods`, ratios against that embree run.
Status run_rows(PaperRunner& pr, const std::vector<PaperScene>& scenes, const std::vector<std::string>& methods) {
  for (const PaperScene& ps : scenes) {
    auto s = make_scene(pr.ctx(), ps);
    if (!s) continue;
    auto emb = pr.measure("embree", ps, *s);
    if (!emb) {  // no reference, no ratio: the row's time goes to the rows that can have one
      pr.ctx().note(ps.group + " " + ps.config + ": no embree run, the row's methods skipped");
      continue;
    }
    pr.add(ps, *s, "embree", emb, emb, long(s->lights.front().samples));
    for (const auto& m : methods) pr.add(ps, *s, m, pr.measure(m, ps, *s), emb, long(s->lights.front().samples));
  }
  pr.finish();
  return {};
}

// Paper 000 section 5.1: image resolutions 512x384, 1024x768, 2048x1536 (as square
// grids of as many receivers), 4x samples and 4x light area at 1024x768. COLUMNS 2,522
// triangles and 256 samples; TREE ~16,500 triangles and 10 lights of 36 samples (foliage
// has one light: 360 samples give the same relations per receiver); SODA 64 samples per
// light, as rooms at 30k, 500k and 2M triangles over 128x128 receivers.
Status run_iss_paper(BenchContext& ctx) {
  const auto& o = ctx.opt;
  PaperRunner pr(ctx);
  std::vector<PaperScene> sc;
  struct Res { const char* name; long w, h; };
  const Res res[] = {{"512x384", 512, 384}, {"1024x768", 1024, 768}, {"2048x1536", 2048, 1536}};
  for (const char* fam : {"columns", "foliage"}) {
    const bool col = std::string(fam) == "columns";
    const long tris = o.quick ? (col ? 300 : 1000) : (col ? 2522 : 16500);
    const long smp = o.quick ? 16 : (col ? 256 : 360);
    auto recv = [&](const Res& r) { return o.quick ? r.w * r.h / 4096 : r.w * r.h; };  // --quick: 48 to 768
    for (const Res& r : res) sc.push_back(paper_scene(o, fam, r.name, fam, tris, recv(r), smp));
    sc.push_back(paper_scene(o, fam, "4x smp", fam, tris, recv(res[1]), smp * 4));
    sc.push_back(paper_scene(o, fam, "4x area", fam, tris, recv(res[1]), smp, 2.0));
  }
  for (long t : o.quick ? std::vector<long>{3000, 6000, 12000} : std::vector<long>{30000, 500000, 2000000})
    sc.push_back(paper_scene(o, "rooms", std::to_string(t / 1000) + "k", "rooms", t, o.quick ? 64 : 128 * 128,
                             o.quick ? 4 : 64));
  return run_rows(pr, sc, {"iss"});
}

// Paper 001 Table 1: 960x540 receivers, 256 samples on one light. Columns 16k
// triangles, Racecar 68k (a dense smooth model: scan), Sponza 109k (architecture:
// rooms), Max 900k (dense foliage). Scenes with several lights (scan: 10, rooms: 48) get
// 256 samples per receiver in total, split over their lights.
Status run_ssv_paper(BenchContext& ctx) {
  const auto& o = ctx.opt;
  PaperRunner pr(ctx);
  struct Row { const char* name; const char* family; long triangles; };
  const Row table1[] = {{"Columns 16k", "columns", 16000}, {"Racecar 68k", "scan", 68000},
                        {"Sponza 109k", "rooms", 109000}, {"Max 900k", "foliage", 900000}};
  std::vector<PaperScene> sc;
  for (const Row& r : table1) {
    const long tris = o.quick ? std::max(300L, r.triangles / 100) : r.triangles;
    PaperScene ps = paper_scene(o, r.name, o.quick ? "quick" : "960x540", r.family, tris, o.quick ? 64 : 960 * 540,
                                o.quick ? 16 : 256);
    FamilyParams one = ps.params;
    one.receivers = 1;
    auto probe = ctx.scene(r.family, one);
    if (probe && probe->lights.size() > 1)
      ps.params.samples = std::max(1L, std::lround(double(ps.params.samples) / double(probe->lights.size())));
    sc.push_back(ps);
  }
  return run_rows(pr, sc, {"ssv"});
}

// Paper 002 Figure 7 at equal quality: T-Rex 26.7k triangles under a long light
// (columns), Sponza with Neptune 116k and Conference 283k (rooms), Soda Hall 2.1M
// (rooms). plucker-bsp's fractions are the exact reference (exact up to its fraction
// tolerance); embree at N = 16, 32, ... samples per light until its penumbra RMS is at
// most 0.5%, then measured fully at that N.
Status run_plucker_paper(BenchContext& ctx) {
  const auto& o = ctx.opt;
  PaperRunner pr(ctx);
  const double quality = 0.005;
  ctx.report.options["equal_quality_penumbra_rms"] = quality;
  struct Row { const char* name; const char* family; long triangles, receivers; };
  const Row fig7[] = {{"T-Rex 27k", "columns", 26673, 128 * 128},
                      {"Sponza 116k", "rooms", 115737, 64 * 64},
                      {"Conference 283k", "rooms", 282873, 64 * 64},
                      {"Soda 2.1M", "rooms", 2147000, 64 * 64}};
  for (const Row& r : fig7) {
    const long tris = o.quick ? std::max(300L, r.triangles / 200) : r.triangles;
    PaperScene ps = paper_scene(o, r.name, o.quick ? "quick" : "equal quality", r.family, tris,
                                o.quick ? 64 : r.receivers, 16);
    auto s = make_scene(ctx, ps);
    if (!s) continue;
    auto exact = pr.measure("plucker-bsp", ps, *s);
    if (!exact) {
      ctx.note(r.name + std::string(": no exact plucker-bsp run, so no equal-quality embree row"));
      continue;
    }
    const std::vector<double> ref = method_fractions(*s, exact->result);
    std::optional<Timing> emb;
    long eq_n = 0;
    double eq_rms = kNaN;
    const std::vector<long> ns = o.quick ? std::vector<long>{16, 64, 256, 1024}
                                         : std::vector<long>{16, 32, 64, 128, 256, 512, 1024, 2048};
    for (long n : ns) {
      PaperScene pn = ps;
      pn.config = "N=" + std::to_string(n);
      pn.params.samples = n;
      auto sn = make_scene(ctx, pn);
      if (!sn) break;
      auto t = pr.measure("embree", pn, *sn);
      if (!t) break;
      const double rms = penumbra_rms(method_fractions(*sn, t->result), ref, nullptr);
      pr.add(pn, *sn, "embree", t, t, n, rms);
      if (rms <= quality || std::isnan(rms)) {
        emb = std::move(t);
        eq_n = n;
        eq_rms = rms;
        break;
      }
    }
    if (!emb)
      ctx.note(r.name + std::string(": embree did not reach the equal quality at N <= ") + std::to_string(ns.back()) +
               " or within the budget: no ratio");
    pr.add(ps, *s, "plucker-bsp", exact, emb, eq_n, eq_rms);
  }
  pr.finish();
  return {};
}

// The scan family at 75k and 300k triangles: 1024 receivers, 64 samples per light (10
// lights). `--families file:PATH,...` runs the same rows on real meshes (a `file:` scene
// each: the mesh kept exactly, one light above it, the receivers below; add `scan` to
// the list to keep the family's rows), e.g. the scans tools/fetch-cgal-data.sh fetches:
// the synthetic family is only a model of them.
Status run_scan(BenchContext& ctx) {
  const auto& o = ctx.opt;
  PaperRunner pr(ctx);
  std::vector<PaperScene> sc;
  const long recv = o.quick ? 64 : 1024, smp = o.quick ? 4 : 64;
  std::vector<std::string> files;
  bool synthetic = o.families.empty();
  for (const auto& f : o.families) {
    if (f.rfind("file:", 0) == 0) files.push_back(f);
    else if (f == "scan") synthetic = true;
    else ctx.note("family " + f + " is not used by this experiment: ignored");
  }
  if (synthetic) {
    for (long t : o.quick ? std::vector<long>{2000, 8000} : std::vector<long>{75000, 300000})
      sc.push_back(paper_scene(o, "scan", std::to_string(t / 1000) + "k", "scan", t, recv, smp));
  }
  for (const auto& f : files) {
    const std::string name = f.substr(f.find_last_of('/') == std::string::npos ? 5 : f.find_last_of('/') + 1);
    sc.push_back(paper_scene(o, name, name, f, -1, recv, smp));
  }
  return run_rows(pr, sc, {"iss", "ssv", "plucker-bsp"});
}

}  // namespace

// Declared in run_method.h.
double method_peak_mb(const Stats& st) {
  double kb = stat_or_nan(st, {"peak_memory_kb"});
  if (!std::isnan(kb)) return kb / 1024.0;
  return stat_or_nan(st, {"peak_memory_mb", "memory_mb"});
}

void ray_cast_shares(const std::string& method, const Stats& st, double relations, double& ray_pct,
                     double& decided_pct) {
  ray_pct = decided_pct = kNaN;
  if (method == "iss") {
    ray_pct = stat_or_nan(st, {"percent_ray_cast"});
    decided_pct = stat_or_nan(st, {"percent_decided_by_shafts"});
    return;
  }
  const double rays = method == "ssv" ? stat_or_nan(st, {"fallback_relations"})
                      : method == "plucker-bsp" ? stat_or_nan(st, {"segment_relations"})
                                                : relations;
  if (relations > 0 && !std::isnan(rays)) {
    ray_pct = 100.0 * rays / relations;
    decided_pct = 100.0 - ray_pct;
  }
}

void add_paper_experiments(std::vector<Experiment>& out) {
  out.push_back({"iss-paper", "paper 000 Tables 5.2/5.3 at the thesis's sizes: ISS against embree", run_iss_paper});
  out.push_back({"ssv-paper", "paper 001 Table 1 settings (960x540, 256 samples): SSV against embree", run_ssv_paper});
  out.push_back({"plucker-paper", "paper 002 Figure 7 at equal quality: plucker-bsp against embree", run_plucker_paper});
  out.push_back({"scan", "the scan family at 75k and 300k triangles: iss, ssv, plucker-bsp against embree", run_scan});
}

}  // namespace visgate::bench
