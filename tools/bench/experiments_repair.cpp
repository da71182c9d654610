// The `visgate bench repair` experiment: throughput of the mesh repair of
// lib/repair/repair.h (`visgate repair`, DESIGN section 7) with the exact predicates of
// lib/repair/cgal_predicates.h, on family meshes of growing size: the analysis alone
// (check_only), repair with exact-position welding (T = 0) and with T = 1e-6.
//
// Sizes: 2000, 16000, 128000 and 1024000 triangles on rooms, columns and torus (a messy
// and a clean 1M-triangle mesh: the target is 1M in under 10 s). random-soup stops at
// 16000: its triangles keep their size in a fixed box, so intersecting pairs grow as n^2
// (371k at 16k triangles, 23.5M at 128k, some 1.5e9 at 1M) and every pair has to be
// decided and counted exactly. A size that gives the same mesh as the previous one (rooms
// has a minimum layout) is skipped with a note.
//
// Times: wall seconds (min over --repeat runs) with one thread and with all threads, and
// the process CPU seconds of those runs (user + system, min over runs): on a shared
// machine the CPU figure is the stable one.
//
// End to end: a smooth closed surface, an icosahedron subdivided 8 times
// (1,310,720 triangles; 5 times with --quick) with its radius modulated smoothly, as a
// scan would be, written as an OFF file and then read, audited, repaired and written
// again by what `visgate repair` runs, on one thread; each phase timed, and the process CPU
// time of the whole (the stable figure on a shared machine).
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>
#include <unordered_map>

#include "lib/repair/repair.h"
#include "lib/repair/repair_input.h"
#include "lib/repair/cgal_predicates.h"
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

// Icosahedron subdivided `levels` times onto a sphere whose radius varies smoothly
// (1 + 0.1 sin 3x cos 2y + 0.05 sin 5z), coordinates rounded to float: a closed, smooth,
// clean surface of 20 * 4^levels triangles.
mesh::IndexedMesh smooth_surface(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                          {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                            {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                            {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                            {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p = p / length(p);
  for (int l = 0; l < levels; ++l) {
    std::unordered_map<uint64_t, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      Vec3d m = (v[a] + v[b]) * 0.5;
      v.push_back(m / length(m));
      mid.emplace(key, uint32_t(v.size() - 1));
      return uint32_t(v.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> g;
    g.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const uint32_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]), ca = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], ab, ca});
      g.push_back({tri[1], bc, ab});
      g.push_back({tri[2], ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = std::move(g);
  }
  mesh::IndexedMesh m;
  for (const auto& p : v) {
    const double r = 1 + 0.1 * std::sin(3 * p.x) * std::cos(2 * p.y) + 0.05 * std::sin(5 * p.z);
    m.vertices.push_back(Vec3d(double(float(p.x * r)), double(float(p.y * r)), double(float(p.z * r))));
  }
  m.triangles = std::move(f);
  return m;
}

// `visgate repair IN -o OUT` on the smooth surface, one thread, phase by phase.
Status run_repair_end_to_end(BenchContext& ctx) {
  const int levels = ctx.opt.quick ? 5 : 8;
  const mesh::IndexedMesh surface = smooth_surface(levels);
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path dir = fs::temp_directory_path(ec) / ("visgate-bench-repair-" + std::to_string(::getpid()));
  fs::create_directories(dir, ec);
  const std::string in = (dir / "smooth.off").string(), out = (dir / "smooth_out.off").string();
  {
    auto bytes = mesh::encode_mesh(surface, mesh::MeshFormat::Off, in);
    if (!bytes) return bytes.error();
    std::ofstream f(in, std::ios::binary);
    f << *bytes;
  }
  mesh::CgalExactPredicates ex;
  Table t{"end_to_end", "visgate repair end to end on a smooth closed surface, one thread (min of --repeat runs)",
          {"triangles", "load_s", "parse_s", "audit_s", "read_s", "repair_s", "analysis_s", "write_s", "total_s", "triangles_per_s", "cpu_s", "triangles_per_cpu_s", "defects_after",
           "pairs_tested", "second_analysis_reused"},
          {}};
  double best = std::numeric_limits<double>::infinity();
  std::vector<Json> row;
  ThreadLimit limit(1);
  for (int rep = 0; rep < std::max(1, ctx.opt.repeat); ++rep) {
    ctx.progress.step("end to end " + std::to_string(surface.triangles.size()) + " triangles");
    using clock = std::chrono::steady_clock;
    auto secs = [](clock::time_point a) { return std::chrono::duration<double>(clock::now() - a).count(); };
    const auto t0 = clock::now();
    const double c0 = cpu_seconds();
    auto decoded = decode_mesh_file(in);
    if (!decoded) return decoded.error();
    const double load_s = secs(t0);
    auto soup = read_polygon_file(in, *decoded);
    if (!soup) return soup.error();
    const double parse_s = secs(t0) - load_s;
    auto audit = mesh::audit_input(in, decoded->bytes, *soup);
    if (!audit) return audit.error();
    const double read_s = secs(t0), audit_s = read_s - load_s - parse_s;
    const auto t1 = clock::now();
    auto r = mesh::repair_mesh(*soup, mesh::RepairOptions{}, ex);
    if (!r) return r.error();
    const double repair_s = secs(t1);
    double analysis_s = 0;
    for (const auto& st : r->steps)
      if (st.name == "analyze_input" || st.name == "analyze_output") analysis_s += st.seconds;
    const auto t2 = clock::now();
    auto enc = mesh::encode_mesh(r->output, mesh::MeshFormat::Off, out);
    if (!enc) return enc.error();
    {
      std::ofstream f(out, std::ios::binary);
      f << *enc;
    }
    const double write_s = secs(t2), total = secs(t0), cpu = cpu_seconds() - c0;
    size_t reused = 0;
    for (const auto& st : r->steps)
      for (const auto& [k, n] : st.changes)
        if (k == "reused_input_analysis") reused = n;
    if (total < best) {
      best = total;
      const double n = double(surface.triangles.size());
      row = {surface.triangles.size(), load_s, parse_s, audit_s, read_s, repair_s, analysis_s, write_s, total, n / total,
             cpu, n / cpu, r->after.defects.total(), r->before.self_intersection_pairs_tested, reused};
    }
  }
  t.add_row(row);
  ctx.report.tables.push_back(std::move(t));
  fs::remove_all(dir, ec);
  return {};
}

Status run_repair(BenchContext& ctx) {
  const auto& o = ctx.opt;
  auto fams = ctx.families({"rooms", "columns", "torus", "random-soup"});
  if (fams.empty()) {
    ctx.note("repair: no family left to measure; only the end-to-end run on the smooth surface");
    return run_repair_end_to_end(ctx);
  }
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

  mesh::CgalExactPredicates ex;
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
  return run_repair_end_to_end(ctx);
}

}  // namespace

void add_repair_experiment(std::vector<Experiment>& out) {
  out.push_back({"repair", "mesh repair throughput (visgate repair) on family meshes", run_repair});
}

}  // namespace visgate::bench
