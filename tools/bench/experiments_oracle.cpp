// The `visgate bench` experiments that measure against the exact oracles:
//   speed-accuracy  seconds against RMS error of the visible fraction (region oracle)
//                   for N = 4..1024 samples; fragment methods (plucker-bsp) as their
//                   exact point; the Pareto chart on log axes;
//   plucker         the analogue of paper 002 section 5, Figures 7-10 on columns and
//                   rooms: equal quality against embree (the smallest N whose RMS error
//                   over the penumbra pairs is at most 0.5%), memory, time split and the
//                   coherence falloff factor (Figure 8, columns MV and FO), light area x1
//                   to x100 and 2 to 36 lights with peak memory;
//   stability       disagreements with the relation oracle per margin decade, every
//                   method on every family (DESIGN section 5), and the mismatch rate
//                   per exact scale 2^k, k from -120 to 124 (DESIGN section 2);
//   oracle          throughput of the relation and region oracles.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "oracle/comparator.h"
#include "oracle/region_oracle.h"
#include "lib/scene/exact_transform.h"
#include "oracle/relation_oracle.h"
#include "tools/bench/bench.h"
#include "tools/bench/run_method.h"

namespace visgate::bench {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// RMS errors of exactly 0 cannot be drawn on a log axis; they are drawn at this floor
// (far below the error of any sampled method at N <= 1024: about 1/(2N) = 5e-4).
constexpr double kLogFloor = 1e-7;

std::string fmt_g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// Exact visible fraction per (receiver, light), receiver-major, by the region oracle;
// pairs in parallel (threads: 0 all).
std::vector<double> exact_fractions(const Scene& s, int threads) {
  size_t L = s.lights.size(), n = s.receivers.size() * L;
  std::vector<double> out(n, 0.0);
  ThreadLimit limit(threads);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) out[k] = oracle::visible_region(s, k / L, k % L).visible_fraction;
  });
  return out;
}

double max_abs_error(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

bool is_fragment_method(const std::string& m) {
  auto s = make_solver(m);
  return s && s->reports_fragments();
}

bool has_option(const std::string& m, const std::string& opt) {
  auto s = make_solver(m);
  if (!s) return false;
  for (const auto& spec : s->options())
    if (spec.name == opt) return true;
  return false;
}

// Scene sizes for the accuracy experiments: the region oracle does exact Boolean
// operations per (receiver, light), so receivers and the rooms tessellation are kept
// small enough for every experiment to finish within minutes on two cores.
FamilyParams accuracy_params(const BenchOptions& o, const std::string& fam) {
  FamilyParams p;
  p.seed = o.seed;
  int side = o.quick ? 4 : (fam == "rooms" ? 8 : 16);
  p.receivers = long(side) * side;
  if (fam == "rooms") p.triangles = o.quick ? 3000 : 6000;
  return p;
}

// ---------------------------------------------------------------------------------
// speed-accuracy

Status run_speed_accuracy(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families({"columns", "foliage", "rooms"});
  if (fams.empty()) return Error{"speed-accuracy: none of the families columns, foliage, rooms is registered"};
  std::vector<long> ns = o.quick ? std::vector<long>{4, 16, 64} : std::vector<long>{4, 16, 64, 256, 1024};
  auto methods = ctx.methods();
  ctx.report.options["samples"] = ns;
  Json sizes = Json::object();

  Table t{"points", "seconds against RMS error of the visible fraction versus the exact region oracle",
          {"family", "method", "samples", "relations", "seconds_1t", "seconds_all", "runs_1t", "runs_all",
           "rms_error", "max_abs_error", "peak_mb"}, {}};
  Table ot{"oracle", "the exact reference: region oracle per (receiver, light)",
           {"family", "receivers", "lights", "triangles", "pairs", "region_oracle_seconds"}, {}};
  for (const auto& fam : fams) {
    FamilyParams p = accuracy_params(o, fam);
    p.samples = ns.front();
    auto base = ctx.scene(fam, p);
    if (!base) return base.error();
    sizes[fam] = scene_summary(*base);
    ctx.progress.step(fam + ": region oracle");
    auto t0 = std::chrono::steady_clock::now();
    std::vector<double> exact = exact_fractions(*base, o.threads);
    double oracle_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ot.add_row({fam, base->receivers.size(), base->lights.size(), base->mesh.size(), exact.size(), oracle_s});

    Chart c{"speed-accuracy-" + fam,
            "Speed against accuracy on " + fam + " (" + std::to_string(base->receivers.size()) +
                " receivers; label: samples N; RMS 0 drawn at 1e-7)",
            "time, single thread (s)", "RMS error of visible fraction (fraction of light area)", true, true, {}};
    SweepGuard guard(o.budget);
    for (const auto& m : methods) {
      bool fragments = is_fragment_method(m);
      Series se{m, {}, {}, {}};
      for (long n : ns) {
        if (fragments && n != ns.front()) break;  // exact: one point
        p.samples = n;
        auto scene = ctx.scene(fam, p);
        if (!scene) return scene.error();
        auto r = run_method(ctx, m, *scene, fam + " N=" + std::to_string(n), &guard, double(n));
        if (!r) continue;
        std::vector<double> got = method_fractions(*scene, r->result);
        double rms = rms_error(got, exact), mx = max_abs_error(got, exact);
        t.add_row({fam, m, fragments ? Json("exact") : Json(n), scene->relation_count(), r->seconds_1t, r->seconds_all,
                   r->runs_1t, r->runs_all, rms, mx, r->peak_mb});
        se.x.push_back(r->seconds());
        se.y.push_back(std::max(rms, kLogFloor));
        se.labels.push_back(fragments ? "exact" : "N=" + std::to_string(n));
      }
      c.series.push_back(std::move(se));
    }
    ctx.report.charts.push_back(std::move(c));
  }
  ctx.report.options["scenes"] = sizes;
  ctx.report.tables.push_back(std::move(t));
  ctx.report.tables.push_back(std::move(ot));
  return {};
}

// ---------------------------------------------------------------------------------
// plucker (paper 002 section 5)

// Replaces the scene's lights by `count` copies of its first light, translated within
// the light's plane to points evenly spaced on a circle about the original centre
// (radius: a third of the receivers' bounding-box diagonal), each with its own seed:
// lights of one size casting comparable shadows, as in paper 002 Figure 10.
Status set_light_count(Scene& s, int count, int samples) {
  if (s.lights.empty() || s.receivers.empty()) return Error{s.name + ": no light or no receiver to copy"};
  Light proto = s.lights.front();
  Vec3d c(0, 0, 0);
  for (const auto& v : proto.polygon) c += to_double(v);
  c = c / double(proto.polygon.size());
  Vec3d n = to_double(proto.normal);
  Vec3d u = to_double(proto.polygon[1]) - to_double(proto.polygon[0]);
  u = u - n * dot(u, n);
  u = u / std::sqrt(dot(u, u));
  Vec3d w = cross(n, u);
  AABB rb;
  for (const auto& r : s.receivers) rb.extend(r.p);
  Vec3d d = to_double(rb.hi) - to_double(rb.lo);
  double radius = std::sqrt(dot(d, d)) / 3.0;
  s.lights.clear();
  for (int k = 0; k < count; ++k) {
    double a = 2.0 * M_PI * double(k) / double(count);
    Vec3d off = (u * std::cos(a) + w * std::sin(a)) * radius;
    Light l;
    for (const auto& v : proto.polygon) l.polygon.push_back(Vec3f(to_double(v) + off));
    l.samples = samples;
    l.pattern = proto.pattern;
    l.jitter = proto.jitter;
    l.seed = proto.seed + uint64_t(k);
    Status st = prepare_light(l, s.name + ": lights[" + std::to_string(k) + "]");
    if (!st) return st;
    s.lights.push_back(std::move(l));
  }
  return {};
}

}  // namespace

// Declared in run_method.h (the paper-scale and target experiments use them too).
std::vector<double> method_fractions(const Scene& s, const SolveResult& r) {
  std::vector<double> out;
  out.reserve(s.receivers.size() * s.lights.size());
  for (const auto& rr : r.receivers)
    for (size_t l = 0; l < s.lights.size(); ++l) out.push_back(l < rr.visible_fraction.size() ? rr.visible_fraction[l] : 0.0);
  return out;
}

double penumbra_rms(const std::vector<double>& got, const std::vector<double>& exact, size_t* count) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t k = 0; k < got.size() && k < exact.size(); ++k) {
    if (!(exact[k] > 0.001 && exact[k] < 0.999)) continue;
    double d = got[k] - exact[k];
    sum += d * d;
    ++n;
  }
  if (count) *count = n;
  return n ? std::sqrt(sum / double(n)) : kNaN;
}

namespace {

// The share of a plucker-bsp solve spent in the tree: stat tree_seconds (every BSP walk
// and development of the queries) over the solver's timed total.
double tree_share(const Stats& ss) {
  double total = ss.get("occluder_selection_seconds") + ss.get("tree_init_seconds") + ss.get("query_seconds");
  return total > 0.0 ? ss.get("tree_seconds") / total : kNaN;
}

// Scene sizes of the plucker experiment: columns at the family's own 64 x 64 receivers,
// rooms (27 lights) at 32 x 32 so that the region oracle (every receiver and light) and
// embree at 1024 samples per light stay within minutes; --quick: 16 x 16 and a smaller
// rooms.
FamilyParams plucker_params(const BenchOptions& o, const std::string& fam) {
  FamilyParams p;
  p.seed = o.seed;
  if (fam == "rooms") {
    p.receivers = o.quick ? 16 * 16 : 32 * 32;
    if (o.quick) p.triangles = 7000;
  } else {
    p.receivers = o.quick ? 16 * 16 : 64 * 64;
  }
  return p;
}

// Figures 9 and 10: plucker-bsp (when `which.plucker`) and embree (`which.embree`) over
// the points `xs`, one scene per point from `scene_at`; per run a row of `table` (from
// `row`), a point of `time` and, for plucker-bsp, of `memory` (its trees' peak). A
// method stops growing past its sweep budget.
struct SweepMethods {
  bool plucker = false, embree = false;
};
Status sweep_figure(BenchContext& ctx, SweepMethods which, const std::vector<double>& xs,
                    const std::function<Result<Scene>(double)>& scene_at,
                    const std::function<std::string(double)>& what,
                    const std::function<std::vector<Json>(double, const std::string&, const Measured&)>& row,
                    Table& table, Chart& time, Chart& memory) {
  const std::string P = "plucker-bsp";
  for (const std::string& m : {P, std::string("embree")}) {
    if ((m == P && !which.plucker) || (m != P && !which.embree)) continue;
    Series ts{m, {}, {}, {}}, ms{m, {}, {}, {}};
    SweepGuard guard(ctx.opt.budget);
    for (double x : xs) {
      auto s = scene_at(x);
      if (!s) return s.error();
      auto r = run_method(ctx, m, *s, what(x) + " " + m, &guard, x);
      if (!r) continue;
      table.add_row(row(x, m, *r));
      ts.x.push_back(x), ts.y.push_back(r->seconds());
      if (m == P) ms.x.push_back(x), ms.y.push_back(r->stats.get("peak_memory_kb"));
    }
    time.series.push_back(std::move(ts));
    if (m == P) memory.series.push_back(std::move(ms));
  }
  return {};
}

// Over 150 lines by design: paper 002's Figures 7 to 10 in order, one block a table, all
// sharing the scenes, the embree sweep and the equal-quality N computed at the top.
Status run_plucker(BenchContext& ctx) {
  const auto& o = ctx.opt;
  const std::string P = "plucker-bsp";
  bool have_p = ctx.has_method(P, "the plucker-bsp figures (the embree side is still measured)");
  bool have_e = ctx.has_method("embree", "the embree comparison");
  auto fams = ctx.families(o.families.empty() ? std::vector<std::string>{"columns", "rooms"} : o.families);
  if (fams.empty()) return Error{"plucker: no registered family to measure"};
  // Equal quality: the smallest N at which embree's RMS error of the visible
  // fraction over the penumbra pairs is at most 0.5%.
  const double quality = 0.005;
  std::vector<long> ns = o.quick ? std::vector<long>{16, 64, 256, 1024} : std::vector<long>{16, 64, 256, 512, 1024, 2048};
  ctx.report.options["families"] = fams;
  ctx.report.options["equal_quality_penumbra_rms"] = quality;
  ctx.report.options["penumbra"] = "exact fraction strictly between 0.001 and 0.999";
  ctx.report.options["embree_samples"] = ns;
  Json sizes = Json::object();

  Table f7{"fig7", "paper 002 Figure 7 analogue: embree at N samples per light against the exact method",
           {"family", "method", "samples", "seconds_1t", "seconds_all", "penumbra_rms", "rms_all", "max_abs_error"}, {}};
  Table eq{"equal", "equal quality: the smallest N with embree's penumbra RMS <= equal_quality_penumbra_rms",
           {"family", "penumbra_pairs", "embree_samples", "embree_seconds_1t", "embree_seconds_all", "embree_penumbra_rms",
            "plucker_seconds_1t", "plucker_seconds_all", "plucker_penumbra_rms", "speedup_1t", "speedup_all",
            "embree_cpu_1t", "plucker_cpu_1t", "speedup_cpu_1t", "paired_rounds", "paired_speedup_1t",
            "paired_speedup_1t_median", "paired_speedup_1t_lo", "paired_speedup_1t_hi", "paired_speedup_cpu_1t",
            "paired_speedup_cpu_1t_median"}, {}};
  Table f8{"fig8", "paper 002 Figure 8 analogue: memory, time split and the coherence falloff factor FO (off / on)",
           {"family", "coherence", "seconds_1t", "seconds_all", "method_peak_kb", "process_peak_mb", "bsp_nodes",
            "developments", "selection_pct", "init_pct", "queries_pct", "falloff_factor_1t", "falloff_factor_all",
            "cpu_1t", "falloff_factor_cpu_1t", "tree_pct", "falloff_bound_1t"}, {}};
  Table st{"stats", "every figure plucker-bsp reports", {"family", "run", "stat", "value"}, {}};
  std::map<std::string, long> eq_samples;  // family -> equal-quality N

  for (const std::string& fam : fams) {
    FamilyParams p = plucker_params(o, fam);
    p.samples = ns.front();
    auto base = ctx.scene(fam, p);
    if (!base) return base.error();
    sizes[fam] = scene_summary(*base);
    ctx.progress.step(fam + ": region oracle");
    std::vector<double> exact = exact_fractions(*base, o.threads);
    size_t pen = 0;
    penumbra_rms(exact, exact, &pen);

    // The exact method (Figure 7 point) and Figure 8: coherence on and off.
    std::optional<Measured> on, off;
    double p_rms = kNaN;
    if (have_p) {
      on = run_method(ctx, P, *base, fam + " coherence on", nullptr, 0.0, {{"coherence", "on"}});
      if (on) {
        auto got = method_fractions(*base, on->result);
        p_rms = penumbra_rms(got, exact, nullptr);
        f7.add_row({fam, P, "exact", on->seconds_1t, on->seconds_all, p_rms, rms_error(got, exact),
                    max_abs_error(got, exact)});
        add_stat_rows(st, {fam, "coherence on"}, on->stats);
      }
      if (has_option(P, "coherence")) {
        off = run_method(ctx, P, *base, fam + " coherence off", nullptr, 0.0, {{"coherence", "off"}});
        if (off) add_stat_rows(st, {fam, "coherence off"}, off->stats);
      } else {
        ctx.note("plucker-bsp has no option coherence: the falloff factor (Figure 8) is not measured");
      }
      // The share of a solve spent in the tree (every BSP walk and development of the
      // queries, stat tree_seconds, of the solver's timed total), and the falloff factor
      // the coherent solve would reach if its tree work cost nothing: off / (on x (1 -
      // on's tree share)). The rest (selection, near polygons, Lambert, bits) is the
      // same work in both modes, so FO cannot exceed this bound.
      for (const auto* m : {&on, &off}) {
        if (!*m) continue;
        const Stats& ss = (*m)->stats;
        bool is_on = m == &on;
        double bound = kNaN;
        if (!is_on && on) bound = ratio((*m)->seconds_1t, on->seconds_1t * (1.0 - tree_share(on->stats)));
        f8.add_row({fam, is_on ? "on" : "off", (*m)->seconds_1t, (*m)->seconds_all, ss.get("peak_memory_kb"),
                    (*m)->peak_mb, ss.get("bsp_nodes"), ss.get("developments"), ss.get("occluder_selection_percent"),
                    ss.get("tree_init_percent"), ss.get("query_percent"),
                    is_on || !on ? Json(1.0) : Json(ratio((*m)->seconds_1t, on->seconds_1t)),
                    is_on || !on ? Json(1.0) : Json(ratio((*m)->seconds_all, on->seconds_all)), (*m)->cpu_1t,
                    is_on || !on ? Json(1.0) : Json(ratio((*m)->cpu_1t, on->cpu_1t)), 100.0 * tree_share(ss), bound});
      }
    }

    // Embree from the smallest N up to the first that reaches the quality.
    Series se{"embree", {}, {}, {}};
    const Measured* eqm = nullptr;
    std::optional<Measured> eq_run;
    std::optional<Scene> eq_scene;
    long eq_n = 0;
    double eq_rms = kNaN;
    if (have_e) {
      SweepGuard guard(o.budget);
      for (long n : ns) {
        p.samples = n;
        auto s = ctx.scene(fam, p);
        if (!s) return s.error();
        auto r = run_method(ctx, "embree", *s, fam + " embree N=" + std::to_string(n), &guard, double(n));
        if (!r) continue;
        auto got = method_fractions(*s, r->result);
        double rms = penumbra_rms(got, exact, nullptr);
        f7.add_row({fam, "embree", n, r->seconds_1t, r->seconds_all, rms, rms_error(got, exact), max_abs_error(got, exact)});
        se.x.push_back(r->seconds());
        se.y.push_back(std::max(rms, kLogFloor));
        se.labels.push_back("N=" + std::to_string(n));
        if (rms <= quality) {
          eq_scene = std::move(*s);
          eq_run = std::move(r);
          eqm = &*eq_run;
          eq_n = n;
          eq_rms = rms;
          break;
        }
      }
    }
    if (eqm && on) {
      // Paired rounds: embree at N and plucker-bsp single-threaded in alternation, so that
      // a slow phase of a shared machine falls on both. Measured on the 2-vCPU cloud VMs
      // this project runs on: a busy sibling hyperthread slows plucker-bsp's branchy walk
      // by up to 45% and embree's SIMD traversal by 3-8%, in phases of seconds, so three
      // back-to-back runs of one method can all land in one; the ratio of the minima over
      // interleaved rounds compares the two at their undisturbed speed, and the median
      // and range of the per-round ratios show how far the phases move it.
      const int rounds = std::max(3, 2 * o.repeat + 1);
      ctx.progress.step(fam + ": embree N=" + std::to_string(eq_n) + " and plucker-bsp, " + std::to_string(rounds) +
                        " paired rounds");
      auto pe = ctx.solver("embree"), pp = ctx.solver(P);  // both ran above: registered
      SolveOptions se_opt, sp_opt;
      se_opt.seed = sp_opt.seed = o.seed;
      sp_opt.opts = {{"coherence", "on"}};
      const PairedTimes pt = measure_paired(*pe, *eq_scene, se_opt, *pp, *base, sp_opt, rounds, ctx.measure_config());
      // Embree's time over plucker-bsp's: the speedup, per round and of the minima.
      const RoundRatios rw = round_ratios(pt.b_seconds, pt.a_seconds), rc = round_ratios(pt.b_cpu, pt.a_cpu);
      eq.add_row({fam, pen, eq_n, eqm->seconds_1t, eqm->seconds_all, eq_rms, on->seconds_1t, on->seconds_all, p_rms,
                  ratio(eqm->seconds_1t, on->seconds_1t), ratio(eqm->seconds_all, on->seconds_all), eqm->cpu_1t,
                  on->cpu_1t, ratio(eqm->cpu_1t, on->cpu_1t), int(pt.a_seconds.size()), rw.of_minima, rw.median, rw.lo,
                  rw.hi, rc.of_minima, rc.median});
      eq_samples[fam] = eq_n;
    } else if (have_e) {
      ctx.note(fam + ": no embree sample count up to " + std::to_string(ns.back()) + " (within the budget) reached a " +
               "penumbra RMS of " + fmt_g(quality) + ": no equal-quality row");
    }
    Chart c{"plucker-fig7-" + fam, "Penumbra RMS against time on " + fam + " (label: samples N; exact drawn at 1e-7)",
            "time, single thread (s)", "RMS error of the visible fraction over the penumbra", true, true, {}};
    c.series.push_back(std::move(se));
    if (on) c.series.push_back({P, {on->seconds()}, {std::max(p_rms, kLogFloor)}, {"exact"}});
    ctx.report.charts.push_back(std::move(c));
  }
  ctx.report.options["scenes"] = sizes;

  // Figure 8 against scene size: the falloff factor on columns (or the first family) at
  // 1, 4 and 16 times the family's triangle count, same receivers and light, one thread.
  // The paper's FO of 16-48 come from scenes of 10^4-10^5 triangles; this measures
  // whether the factor grows with the number of occluders per tree, with the work
  // counters of both modes (the coherent tree saves developments and insertion tests;
  // its walk is longer than a fresh tree's, which holds only the current query's
  // classes). A run longer than 5 s is not repeated.
  Table f8s{"fig8-scale", "the falloff factor FO (off / on, one thread) as the scene grows",
            {"family", "triangles", "occluders", "seconds_on", "seconds_off", "falloff_factor_1t", "tree_pct_on",
             "falloff_bound_1t", "developments_on", "developments_off", "insert_tests_on", "insert_tests_off",
             "node_visits_on", "node_visits_off", "splits_on", "splits_off"}, {}};
  if (have_p && has_option(P, "coherence")) {
    const std::string sfam = std::find(fams.begin(), fams.end(), "columns") != fams.end() ? "columns" : fams.front();
    MeasureConfig mc = ctx.measure_config();
    mc.all = false;
    mc.budget = std::min(mc.budget, 5.0);
    long base_tris = 0;
    for (long factor : o.quick ? std::vector<long>{1, 4} : std::vector<long>{1, 4, 16}) {
      FamilyParams q = plucker_params(o, sfam);
      q.samples = 16;
      if (factor > 1) q.triangles = base_tris * factor;
      auto sc = ctx.scene(sfam, q);
      if (!sc) return sc.error();
      if (factor == 1) base_tris = long(sc->mesh.size());
      std::optional<Measured> m[2];
      for (int k = 0; k < 2; ++k) {
        const std::string mode = k == 0 ? "on" : "off";
        m[k] = run_method(ctx, P, *sc, sfam + " " + std::to_string(sc->mesh.size()) + " triangles coherence " + mode,
                          nullptr, 0.0, {{"coherence", mode}}, &mc);
      }
      if (!m[0] || !m[1]) continue;
      const Stats &a = m[0]->stats, &b = m[1]->stats;
      const double share = tree_share(a);
      f8s.add_row({sfam, long(sc->mesh.size()), a.get("occluders"), m[0]->seconds_1t, m[1]->seconds_1t,
                   ratio(m[1]->seconds_1t, m[0]->seconds_1t), 100.0 * share,
                   ratio(m[1]->seconds_1t, m[0]->seconds_1t * (1.0 - share)), a.get("developments"),
                   b.get("developments"), a.get("insert_tests"), b.get("insert_tests"), a.get("node_visits"),
                   b.get("node_visits"), a.get("splits"), b.get("splits")});
    }
  }

  // Figure 9: light area x1 to x100 (side x1 to x10), on columns (or the first family).
  const std::string f9fam = std::find(fams.begin(), fams.end(), "columns") != fams.end() ? "columns" : fams.front();
  std::vector<double> areas = o.quick ? std::vector<double>{1, 16} : std::vector<double>{1, 4, 16, 36, 64, 100};
  const long f9n = eq_samples.count(f9fam) ? eq_samples[f9fam] : 256;
  Table f9{"fig9", "paper 002 Figure 9 analogue: time and peak memory as the light area grows (" + f9fam + ")",
           {"area_factor", "method", "samples", "seconds_1t", "seconds_all", "method_peak_kb", "process_peak_mb",
            "bsp_nodes", "fragments"}, {}};
  Chart c9t{"plucker-fig9-time", "Time against light area on " + f9fam, "light area (x the original)",
            "time, single thread (s)", true, true, {}};
  Chart c9m{"plucker-fig9-memory", "Peak memory of plucker-bsp's trees against light area on " + f9fam,
            "light area (x the original)", "peak memory of the trees (KiB)", true, false, {}};
  auto area_scene = [&](double a) {
    FamilyParams q = plucker_params(o, f9fam);
    q.samples = f9n;
    q.light_scale = std::sqrt(a);
    return ctx.scene(f9fam, q);
  };
  auto f9_row = [&](double a, const std::string& m, const Measured& r) {
    const bool pm = m == P;
    return std::vector<Json>{a, m, pm ? Json("exact") : Json(f9n), r.seconds_1t, r.seconds_all,
                             pm ? Json(r.stats.get("peak_memory_kb")) : Json(kNaN), r.peak_mb,
                             pm ? Json(r.stats.get("bsp_nodes")) : Json(kNaN),
                             pm ? Json(r.stats.get("fragments")) : Json(kNaN)};
  };
  Status st9 = sweep_figure(ctx, {have_p, have_e}, areas, area_scene,
                            [&](double a) { return f9fam + " light area x" + fmt_g(a); }, f9_row, f9, c9t, c9m);
  if (!st9) return st9;
  ctx.report.charts.push_back(std::move(c9t));
  ctx.report.charts.push_back(std::move(c9m));

  // Figure 10: 2 to 36 lights of one size, on rooms (or the first family).
  const std::string f10fam = std::find(fams.begin(), fams.end(), "rooms") != fams.end() ? "rooms" : fams.front();
  std::vector<int> counts = o.quick ? std::vector<int>{2, 8} : std::vector<int>{2, 4, 8, 16, 36};
  const long f10n = eq_samples.count(f10fam) ? eq_samples[f10fam] : 256;
  Table f10{"fig10", "paper 002 Figure 10 analogue: time and peak memory against the number of lights (" + f10fam + ")",
            {"lights", "method", "samples_per_light", "seconds_1t", "seconds_all", "method_peak_kb", "process_peak_mb",
             "bsp_nodes"}, {}};
  Chart c10t{"plucker-fig10-time", "Time against the number of lights on " + f10fam, "lights", "time, single thread (s)",
             true, true, {}};
  Chart c10m{"plucker-fig10-memory", "Peak memory of plucker-bsp's trees against the number of lights on " + f10fam,
             "lights", "peak memory of the trees (KiB)", true, false, {}};
  auto count_scene = [&](double k) -> Result<Scene> {
    FamilyParams q = plucker_params(o, f10fam);
    q.samples = f10n;
    auto s = ctx.scene(f10fam, q);
    if (!s) return s.error();
    Status ls = set_light_count(*s, int(k), int(f10n));
    if (!ls) return ls.error();
    return s;
  };
  auto f10_row = [&](double k, const std::string& m, const Measured& r) {
    const bool pm = m == P;
    return std::vector<Json>{int(k), m, pm ? Json("exact") : Json(f10n), r.seconds_1t, r.seconds_all,
                             pm ? Json(r.stats.get("peak_memory_kb")) : Json(kNaN), r.peak_mb,
                             pm ? Json(r.stats.get("bsp_nodes")) : Json(kNaN)};
  };
  std::vector<double> count_xs(counts.begin(), counts.end());
  Status st10 = sweep_figure(ctx, {have_p, have_e}, count_xs, count_scene,
                             [&](double k) { return f10fam + " " + std::to_string(int(k)) + " lights"; }, f10_row, f10,
                             c10t, c10m);
  if (!st10) return st10;
  ctx.report.charts.push_back(std::move(c10t));
  ctx.report.charts.push_back(std::move(c10m));

  ctx.report.tables.push_back(std::move(eq));
  ctx.report.tables.push_back(std::move(f7));
  if (!f8.rows.empty()) ctx.report.tables.push_back(std::move(f8));
  if (!f8s.rows.empty()) ctx.report.tables.push_back(std::move(f8s));
  ctx.report.tables.push_back(std::move(f9));
  ctx.report.tables.push_back(std::move(f10));
  if (!st.rows.empty()) ctx.report.tables.push_back(std::move(st));
  return {};
}

// ---------------------------------------------------------------------------------
// stability

// Lower bound of histogram bucket k (oracle::DecadeHistogram): 10^(k-12).
double decade_low(size_t k) { return std::pow(10.0, double(k) - 12.0); }

// The scale axis: mismatch rate of every method, baselines as their users run them, on
// exact 2^k copies of every family's scene (DESIGN section 2, "Scale"). The production
// methods solve the unit copy and so do not depend on k; Embree (and the leaf rays of any
// method that handed it an unnormalised scene) does.
void run_stability_scale(BenchContext& ctx, const std::vector<std::string>& fams, const std::vector<std::string>& methods) {
  const auto& o = ctx.opt;
  static constexpr int kExponents[] = {-120, -96, -64, -48, -40, -37, -32, -16, 0, 16, 32, 43, 48, 64, 66, 96, 124};
  const long receivers = o.quick ? 16 : 64, samples = 16, triangles = o.quick ? 60 : 100;
  ctx.report.options["scale_receivers"] = receivers;
  ctx.report.options["scale_samples"] = samples;
  ctx.report.options["scale_triangles"] = triangles;
  Table tab{"scale", "mismatches against the relation oracle on exact 2^k copies (k clamped per scene to where the "
                     "copy is exact; k_applied its mean), one scene per family",
            {"k", "method", "scenes", "k_applied_mean", "relations", "mismatches", "false_visible", "false_blocked",
             "mismatch_rate"}, {}};
  Chart c{"stability-scale", "Mismatch rate on exact 2^k copies of every family (tau " + fmt_g(o.tau) + ")",
          "k (scene scaled by 2^k)", "mismatches per relation", false, false, {}};
  std::map<std::string, Series> series;
  for (int k : kExponents) {
    std::map<std::string, oracle::Comparison> acc;
    double applied = 0;
    int scenes = 0;
    for (const auto& fam : fams) {
      if (fam == "rooms") continue;  // thousands of triangles at its smallest: the other families cover it
      FamilyParams p;
      p.seed = o.seed;
      p.receivers = receivers;
      p.samples = samples;
      p.triangles = triangles;
      p.scale_exponent = k;
      auto s = generate_family(fam, p);
      if (!s) {
        ctx.note("scale 2^" + std::to_string(k) + " family " + fam + ": " + s.error().message + ": skipped");
        continue;
      }
      FamilyParams p0 = p;
      p0.scale_exponent = 0;
      Result<Scene> unscaled = generate_family(fam, p0);
      const int kk = unscaled ? unit_scale_exponent(*unscaled) - unit_scale_exponent(*s) : 0;
      applied += kk;
      ++scenes;
      ctx.progress.step("scale 2^" + std::to_string(k) + " " + fam + ": relation oracle");
      const auto exact = oracle::run_relation_oracle(*s, o.threads);
      for (const auto& m : methods) {
        ctx.progress.step("scale 2^" + std::to_string(k) + " " + fam + ": " + m);
        SolveOptions so;
        so.seed = o.seed;
        so.threads = o.threads;
        const SolveResult r = make_solver(m)->solve(*s, so);
        const auto cmp = oracle::compare_relations(*s, r, exact, o.tau);
        auto& a = acc[m];
        a.relations += cmp.relations, a.false_visible += cmp.false_visible, a.false_blocked += cmp.false_blocked;
        a.fraction_mismatches += cmp.fraction_mismatches, a.fragment_mismatches += cmp.fragment_mismatches;
      }
    }
    for (const auto& m : methods) {
      if (!acc.count(m)) continue;
      const auto& a = acc[m];
      const double rate = double(a.mismatch_count()) / double(std::max<size_t>(1, a.relations));
      tab.add_row({k, m, scenes, scenes ? applied / scenes : 0.0, a.relations, a.mismatch_count(), a.false_visible,
                   a.false_blocked, rate});
      Series& se = series[m];
      se.name = m;
      se.x.push_back(double(k));
      se.y.push_back(rate);
      se.labels.push_back("");
    }
  }
  for (const auto& m : methods)
    if (series.count(m)) c.series.push_back(std::move(series[m]));
  ctx.report.charts.push_back(std::move(c));
  ctx.report.tables.push_back(std::move(tab));
}

Status run_stability(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families(o.families.empty() ? family_names() : o.families);
  auto methods = ctx.methods();
  int seeds = o.quick ? 1 : 3;
  long receivers = o.quick ? 64 : 1024, samples = o.quick ? 4 : 16;
  ctx.report.options["seeds"] = seeds;
  ctx.report.options["receivers"] = receivers;
  ctx.report.options["samples"] = samples;
  ctx.report.options["tau"] = o.tau;

  Table sum{"summary", "disagreements with the relation oracle, every method on every family (all seeds)",
            {"family", "method", "relations", "degenerate", "disagreements", "mismatches", "false_visible",
             "false_blocked", "fraction_mismatches", "fragment_mismatches", "disagreement_rate", "mismatch_rate"}, {}};
  Table dec{"decades", "disagreements per margin decade [low, 10 low); low 0 holds margins below 1e-12",
            {"family", "method", "margin_low", "disagreements", "rate"}, {}};
  std::map<std::string, oracle::DecadeHistogram> total_hist;
  std::map<std::string, size_t> total_rel;
  for (const auto& fam : fams) {
    std::map<std::string, oracle::Comparison> acc;
    std::map<std::string, size_t> rel;
    for (int sd = 0; sd < seeds; ++sd) {
      FamilyParams p;
      p.seed = o.seed + uint64_t(sd);
      p.receivers = receivers;
      p.samples = samples;
      // Small meshes with --quick; rooms (30k triangles, 27 lights by default) and scan
      // (20k, 10 lights) reduced so the exact methods finish in minutes.
      if (o.quick) p.triangles = 300;
      else if (fam == "rooms") p.triangles = 6000;
      else if (fam == "scan") p.triangles = 3000;
      auto s = ctx.scene(fam, p);
      if (!s) {
        ctx.note("family " + fam + " seed " + std::to_string(p.seed) + ": " + s.error().message + ": skipped");
        continue;
      }
      ctx.progress.step(fam + " seed " + std::to_string(p.seed) + ": relation oracle");
      auto exact = oracle::run_relation_oracle(*s, o.threads);
      for (const auto& m : methods) {
        auto solver = make_solver(m);
        ctx.progress.step(fam + " seed " + std::to_string(p.seed) + ": " + m);
        SolveOptions so;
        so.seed = o.seed;
        so.threads = o.threads;
        SolveResult r = solver->solve(*s, so);
        auto cmp = oracle::compare_relations(*s, r, exact, o.tau);
        auto& a = acc[m];
        a.relations += cmp.relations, a.degenerate += cmp.degenerate, a.agree += cmp.agree;
        a.disagree += cmp.disagree, a.false_visible += cmp.false_visible, a.false_blocked += cmp.false_blocked;
        a.fraction_mismatches += cmp.fraction_mismatches, a.fragment_mismatches += cmp.fragment_mismatches;
        for (size_t k = 0; k < a.disagreement_margins.buckets.size(); ++k)
          a.disagreement_margins.buckets[k] += cmp.disagreement_margins.buckets[k];
        a.disagreement_margins.below += cmp.disagreement_margins.below;
        rel[m] += cmp.relations;
      }
    }
    Chart c{"stability-" + fam, "Disagreement rate per margin decade on " + fam + " (tau " + fmt_g(o.tau) + ")",
            "margin (relative to scene diagonal; 1e-13: below 1e-12)", "disagreements per relation", true, true, {}};
    for (const auto& m : methods) {
      if (!acc.count(m)) continue;
      const auto& a = acc[m];
      double n = double(std::max<size_t>(1, a.relations));
      sum.add_row({fam, m, a.relations, a.degenerate, a.disagree, a.mismatch_count(), a.false_visible, a.false_blocked,
                   a.fraction_mismatches, a.fragment_mismatches, double(a.disagree) / n,
                   double(a.mismatch_count()) / n});
      Series se{m, {}, {}, {}};
      auto add = [&](double low, size_t count) {
        dec.add_row({fam, m, low, count, double(count) / n});
        se.x.push_back(low == 0 ? 1e-13 : low);
        se.y.push_back(double(count) / n);
        se.labels.push_back("");
      };
      add(0.0, a.disagreement_margins.below);
      for (size_t k = 0; k < a.disagreement_margins.buckets.size(); ++k) add(decade_low(k), a.disagreement_margins.buckets[k]);
      c.series.push_back(std::move(se));
      auto& th = total_hist[m];
      for (size_t k = 0; k < th.buckets.size(); ++k) th.buckets[k] += a.disagreement_margins.buckets[k];
      th.below += a.disagreement_margins.below;
      total_rel[m] += a.relations;
    }
    ctx.report.charts.push_back(std::move(c));
  }
  Chart all{"stability-all", "Disagreement rate per margin decade, all families (tau " + fmt_g(o.tau) + ")",
            "margin (relative to scene diagonal; 1e-13: below 1e-12)", "disagreements per relation", true, true, {}};
  for (const auto& m : methods) {
    if (!total_hist.count(m)) continue;
    const auto& h = total_hist[m];
    double n = double(std::max<size_t>(1, total_rel[m]));
    Series se{m, {1e-13}, {double(h.below) / n}, {""}};
    for (size_t k = 0; k < h.buckets.size(); ++k) {
      se.x.push_back(decade_low(k));
      se.y.push_back(double(h.buckets[k]) / n);
      se.labels.push_back("");
    }
    all.series.push_back(std::move(se));
  }
  ctx.report.charts.push_back(std::move(all));
  ctx.report.tables.push_back(std::move(sum));
  ctx.report.tables.push_back(std::move(dec));
  run_stability_scale(ctx, fams, methods);
  return {};
}

// ---------------------------------------------------------------------------------
// oracle throughput

Status run_oracle(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families(o.families.empty() ? family_names() : o.families);
  long receivers = o.quick ? 64 : 1024, samples = o.quick ? 4 : 16;
  size_t region_pairs = o.quick ? 16 : 128;  // (receiver, light) pairs timed for the region oracle
  ctx.report.options["receivers"] = receivers;
  ctx.report.options["samples"] = samples;
  ctx.report.options["region_pairs"] = region_pairs;
  int all_threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  Table t{"throughput", "exact oracle throughput (min of --repeat runs)",
          {"family", "triangles", "relations", "relation_seconds_1t", "relation_seconds_all", "relations_per_s_1t",
           "relations_per_s_all", "relation_peak_mb", "degenerate", "region_pairs", "region_seconds_1t",
           "region_seconds_all", "regions_per_s_1t", "regions_per_s_all", "region_peak_mb"}, {}};
  Chart chart{"oracle-throughput", "Exact oracle throughput per family (label: family)", "scene triangles",
              "answers per second, single thread (relations or regions /s)", true, true, {}};
  Series rel_series{"relation-oracle", {}, {}, {}}, reg_series{"region-oracle", {}, {}, {}};
  for (const auto& fam : fams) {
    FamilyParams p;
    p.seed = o.seed;
    p.receivers = receivers;
    p.samples = samples;
    if (o.quick) p.triangles = 300;
    auto s = ctx.scene(fam, p);
    if (!s) {
      ctx.note("family " + fam + ": " + s.error().message + ": skipped");
      continue;
    }
    size_t degenerate = 0;
    ctx.progress.step(fam + ": relation oracle, 1 thread");
    Timed r1 = time_min(o.repeat, o.budget, [&] {
      auto r = oracle::run_relation_oracle(*s, 1);
      degenerate = 0;
      for (const auto& c : r.classes) degenerate += size_t(std::count(c.begin(), c.end(), 'd'));
    });
    ctx.progress.step(fam + ": relation oracle, all threads");
    Timed ra = time_min(o.repeat, o.budget, [&] { oracle::run_relation_oracle(*s, all_threads); });
    // Region oracle on the first pairs (receiver-major) of the scene.
    size_t L = s->lights.size(), pairs = std::min(region_pairs, s->receivers.size() * L);
    auto regions = [&](int threads) {
      ThreadLimit limit(threads);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, pairs, 1), [&](const tbb::blocked_range<size_t>& rg) {
        for (size_t k = rg.begin(); k != rg.end(); ++k) oracle::visible_region(*s, k / L, k % L);
      });
    };
    ctx.progress.step(fam + ": region oracle");
    Timed g1 = time_min(o.repeat, o.budget, [&] { regions(1); });
    Timed ga = time_min(o.repeat, o.budget, [&] { regions(all_threads); });
    double rel = double(s->relation_count());
    t.add_row({fam, s->mesh.size(), s->relation_count(), r1.seconds, ra.seconds, ratio(rel, r1.seconds),
               ratio(rel, ra.seconds), std::max(r1.peak_mb, ra.peak_mb), degenerate, pairs, g1.seconds, ga.seconds,
               ratio(double(pairs), g1.seconds), ratio(double(pairs), ga.seconds), std::max(g1.peak_mb, ga.peak_mb)});
    const double tris = double(s->mesh.size());
    rel_series.x.push_back(tris), rel_series.y.push_back(ratio(rel, r1.seconds)), rel_series.labels.push_back(fam);
    reg_series.x.push_back(tris), reg_series.y.push_back(ratio(double(pairs), g1.seconds)), reg_series.labels.push_back(fam);
  }
  add_sorted(chart, std::move(rel_series));
  add_sorted(chart, std::move(reg_series));
  ctx.report.charts.push_back(std::move(chart));
  ctx.report.tables.push_back(std::move(t));
  return {};
}

}  // namespace

void add_oracle_experiments(std::vector<Experiment>& out) {
  out.push_back({"speed-accuracy", "seconds against RMS error versus the exact region oracle, N = 4..1024 samples",
                 run_speed_accuracy});
  out.push_back({"plucker", "paper 002 Figures 7-10 analogue: plucker-bsp against embree", run_plucker});
  out.push_back({"stability", "disagreement rate per margin decade, every method on every family", run_stability});
  out.push_back({"oracle", "throughput of the relation and region oracles", run_oracle});
}

}  // namespace visgate::bench
