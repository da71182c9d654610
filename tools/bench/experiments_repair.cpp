// The `visgate bench repair` experiment: throughput of the mesh repair of
// lib/mesh/repair.h (`visgate repair`, DESIGN section 7) with the exact predicates of
// oracle/exact_predicates.h, on family meshes of growing size: the analysis alone
// (check_only), repair with exact-position welding (T = 0) and with T = 1e-6.
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

Status run_repair(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families({"rooms", "columns", "torus", "random-soup"});
  if (fams.empty()) return Error{"repair: no registered family to measure"};
  std::vector<long> sizes = o.quick ? std::vector<long>{1000, 4000} : std::vector<long>{2000, 16000, 128000, 1024000};
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
  ctx.report.options["modes"] = {"check-only", "repair T=0", "repair T=1e-6"};
  int all_threads = o.threads > 0 ? o.threads : int(std::max(1u, std::thread::hardware_concurrency()));

  oracle::CgalExactPredicates ex;
  Table t{"throughput", "mesh repair throughput (min of --repeat runs)",
          {"family", "mode", "input_vertices", "input_triangles", "seconds_1t", "seconds_all", "triangles_per_s_1t",
           "triangles_per_s_all", "peak_mb", "defects_before", "defects_after", "output_triangles"}, {}};
  Chart c{"repair-throughput", "Mesh repair time against triangles (single thread)", "input triangles",
          "time, single thread (s)", true, true, {}};
  std::map<std::string, Series> series;
  for (const auto& fam : fams) {
    SweepGuard guard(o.budget);
    for (long n : sizes) {
      FamilyParams p;
      p.seed = o.seed;
      p.triangles = n;
      p.receivers = 1;
      p.samples = 1;
      auto s = ctx.scene(fam, p);
      if (!s) return s.error();
      PolygonSoup soup = to_polygon_soup(s->mesh);
      double tris = double(soup.faces.size());
      for (const auto& m : modes) {
        std::string key = fam + " " + m.name, why;
        if (guard.skip(key, tris, &why)) {
          ctx.note("repair " + key + " skipped at " + std::to_string(long(tris)) + " triangles: " + why);
          continue;
        }
        ctx.progress.step(key + " " + std::to_string(long(tris)) + " triangles");
        size_t before = 0, after = 0, out_tris = 0;
        bool failed = false;
        auto once = [&] {
          auto r = mesh::repair_mesh(soup, m.opt, ex);
          if (!r) {
            failed = true;
            return;
          }
          before = r->before.defects.total();
          after = m.opt.check_only ? before : r->after.defects.total();
          out_tris = r->output.triangles.size();
        };
        Timed t1, ta;
        {
          ThreadLimit limit(1);
          t1 = time_min(o.repeat, o.budget, once);
        }
        {
          ThreadLimit limit(all_threads);
          ta = time_min(o.repeat, o.budget, once);
        }
        if (failed) {
          ctx.note("repair " + key + ": repair_mesh rejected the input: skipped");
          continue;
        }
        guard.record(key, tris, t1.seconds);
        t.add_row({fam, m.name, soup.vertices.size(), soup.faces.size(), t1.seconds, ta.seconds,
                   tris / t1.seconds, tris / ta.seconds, std::max(t1.peak_mb, ta.peak_mb), before, after, out_tris});
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
