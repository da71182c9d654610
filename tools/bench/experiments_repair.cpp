// The `visgate bench repair` experiment: throughput of the mesh repair of
// lib/mesh/repair.h (`visgate repair`, DESIGN section 7) with the exact predicates of
// oracle/exact_predicates.h, on family meshes of growing size: the analysis alone
// (check_only), repair with exact-position welding (T = 0) and with T = 1e-6.
//
// Sizes: 2000, 16000, 128000 and 1024000 triangles on rooms, columns and torus (a messy
// and a clean 1M-triangle mesh: issue 9 asks for 1M in under 10 s). random-soup stops at
// 16000: its triangles keep their size in a fixed box, so intersecting pairs grow as n^2
// (371k at 16k triangles, 23.5M at 128k, some 1.5e9 at 1M) and every pair has to be
// decided and counted exactly. A size that gives the same mesh as the previous one (rooms
// has a minimum layout) is skipped with a note.
//
// Times: wall seconds (min over --repeat runs) with one thread and with all threads, and
// the process CPU seconds of those runs (user + system, min over runs): on a shared
// machine the CPU figure is the stable one.
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "lib/mesh/repair.h"
#include "oracle/exact_predicates.h"
#include "tools/bench/bench.h"

namespace visgate::bench {

namespace {

PolygonSoup to_polygon_soup(const TriangleSoup& t) {
  PolygonSoup p;
  p.vertices.reserve(t.vertices.size());
  for (const auto& v : t.vertices) p.vertices.push_back(to_double(v));
  p.faces.reserve(t.triangles.size());
  for (const auto& tri : t.triangles) p.faces.push_back({tri[0], tri[1], tri[2]});
  return p;
}

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec) + double(u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_stime.tv_usec);
}

Status run_repair(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families({"rooms", "columns", "torus", "random-soup"});
  if (fams.empty()) return Error{"repair: no registered family to measure"};
  const std::vector<long> sizes = o.quick ? std::vector<long>{1000, 4000} : std::vector<long>{2000, 16000, 128000, 1024000};
  auto sizes_of = [&](const std::string& fam) {
    if (fam != "random-soup" || o.quick) return sizes;
    std::vector<long> capped;
    for (long n : sizes)
      if (n <= 16000) capped.push_back(n);
    return capped;
  };
  if (!o.quick && std::find(fams.begin(), fams.end(), "random-soup") != fams.end())
    ctx.note("repair random-soup measured up to 16000 triangles: intersecting pairs grow as n^2 there "
             "(371k at 16k, 23.5M at 128k)");
  struct Mode {
    std::string name;
    mesh::RepairOptions opt;
  };
  std::vector<Mode> modes(3);
  modes[0].name = "check-only";
  modes[0].opt.check_only = true;
  modes[1].name = "repair T=0";
  modes[2].name = "repair T=1e-6";
  modes[2].opt.weld_tolerance = 1e-6;
  ctx.report.options["sizes"] = sizes;
  ctx.report.options["timing"] =
      "seconds: minimum over the runs of the wall time of repair_mesh (triangulation, the analyses and every step; "
      "mesh generation excluded); cpu_seconds: process CPU time (user + system) of those runs, minimum; _1t one "
      "thread, _all threads_all threads";
  ctx.report.options["modes"] = {"check-only", "repair T=0", "repair T=1e-6"};
  int all_threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));

  oracle::CgalExactPredicates ex;
  Table t{"throughput", "mesh repair throughput (min of --repeat runs)",
          {"family", "mode", "input_vertices", "input_triangles", "seconds_1t", "seconds_all", "cpu_seconds_1t",
           "cpu_seconds_all", "triangles_per_s_1t", "triangles_per_s_all", "peak_mb", "defects_before", "defects_after",
           "self_intersections_before", "self_intersections_after", "pairs_tested", "output_triangles"}, {}};
  Chart c{"repair-throughput", "Mesh repair time against triangles (single thread)", "input triangles",
          "time, single thread (s)", true, true, {}};
  std::map<std::string, Series> series;
  for (const auto& fam : fams) {
    SweepGuard guard(o.budget);
    size_t previous = 0;
    for (long n : sizes_of(fam)) {
      FamilyParams p;
      p.seed = o.seed;
      p.triangles = n;
      p.receivers = 1;
      p.samples = 1;
      auto s = ctx.scene(fam, p);
      if (!s) return s.error();
      PolygonSoup soup = to_polygon_soup(s->mesh);
      double tris = double(soup.faces.size());
      if (soup.faces.size() == previous) {
        ctx.note("repair " + fam + " at " + std::to_string(n) + " triangles gives the same " +
                 std::to_string(previous) + "-triangle mesh as the previous size: skipped");
        continue;
      }
      previous = soup.faces.size();
      for (const auto& m : modes) {
        std::string key = fam + " " + m.name, why;
        if (guard.skip(key, tris, &why)) {
          ctx.note("repair " + key + " skipped at " + std::to_string(long(tris)) + " triangles: " + why);
          continue;
        }
        ctx.progress.step(key + " " + std::to_string(long(tris)) + " triangles");
        size_t before = 0, after = 0, out_tris = 0, si_before = 0, si_after = 0, pairs = 0;
        bool failed = false;
        double cpu = 0;
        auto once = [&] {
          const double c0 = cpu_seconds();
          auto r = mesh::repair_mesh(soup, m.opt, ex);
          const double used = cpu_seconds() - c0;
          cpu = std::isnan(cpu) ? used : std::min(cpu, used);
          if (!r) {
            failed = true;
            return;
          }
          before = r->before.defects.total();
          after = m.opt.check_only ? before : r->after.defects.total();
          si_before = r->before.defects.self_intersections;
          si_after = m.opt.check_only ? si_before : r->after.defects.self_intersections;
          pairs = r->before.self_intersection_pairs_tested;
          out_tris = r->output.triangles.size();
        };
        Timed t1, ta;
        double cpu_1t = 0, cpu_all = 0;
        {
          ThreadLimit limit(1);
          cpu = std::numeric_limits<double>::quiet_NaN();
          t1 = time_min(o.repeat, o.budget, once);
          cpu_1t = cpu;
        }
        {
          ThreadLimit limit(all_threads);
          cpu = std::numeric_limits<double>::quiet_NaN();
          ta = time_min(o.repeat, o.budget, once);
          cpu_all = cpu;
        }
        if (failed) {
          ctx.note("repair " + key + ": repair_mesh rejected the input: skipped");
          continue;
        }
        guard.record(key, tris, t1.seconds);
        t.add_row({fam, m.name, soup.vertices.size(), soup.faces.size(), t1.seconds, ta.seconds, cpu_1t, cpu_all,
                   tris / t1.seconds, tris / ta.seconds, std::max(t1.peak_mb, ta.peak_mb), before, after, si_before,
                   si_after, pairs, out_tris});
        if (m.name == "repair T=0") {
          auto& se = series[fam];
          se.name = fam;
          se.x.push_back(tris);
          se.y.push_back(t1.seconds);
          se.labels.push_back("");
        }
      }
    }
  }
  for (auto& [k, se] : series) c.series.push_back(std::move(se));
  ctx.report.charts.push_back(std::move(c));
  ctx.report.tables.push_back(std::move(t));
  return {};
}

}  // namespace

void add_repair_experiment(std::vector<Experiment>& out) {
  out.push_back({"repair", "mesh repair throughput (visgate repair) on family meshes", run_repair});
}

}  // namespace visgate::bench
