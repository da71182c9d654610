// visgate oracle scene.json [--regions] [--threads N] [--tau T] [-o oracle.json]
// Runs the exact relation oracle (and with --regions the region oracle for every
// receiver and light) and writes the oracle JSON of DESIGN section 5.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "lib/scene/scene_json.h"
#include "lib/solver.h"
#include "oracle/oracle_json.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct OracleOpts {
  static constexpr const char* kHelp = "Exact classes and margins of every relation (and visible regions)";
  std::string scene, out;
  bool regions = false;
  int threads = 0;
  double tau = oracle::kDefaultTau;
  void bind(CLI::App* sub) {
    sub->add_option("scene", scene, "Scene JSON")->required();
    sub->add_flag("--regions", regions, "Also compute the exact visible region per receiver and light");
    sub->add_option("--threads", threads, "Threads (0: all)");
    sub->add_option("--tau", tau, "Margin threshold written to the file (default 1e-5)");
    sub->add_option("-o,--output", out, "Oracle JSON ('-' for stdout)");
  }
};

int run_oracle(const OracleOpts& o) {
  if (o.threads < 0) return bad_input("--threads " + std::to_string(o.threads) + ": expected >= 0");
  if (!(o.tau >= 0.0) || !std::isfinite(o.tau)) return bad_input("--tau: expected a finite number >= 0");
  auto scene = read_scene_file(o.scene);
  if (!scene) return bad_input(scene.error());
  oracle::RelationOracleResult rel = oracle::run_relation_oracle(*scene, o.threads);
  size_t counts[3] = {0, 0, 0};
  for (const auto& c : rel.classes)
    for (char ch : c) ++counts[ch == 'v' ? 0 : (ch == 'b' ? 1 : 2)];
  size_t relations = scene->relation_count();
  std::fprintf(stderr, "oracle on %s: %zu triangles, %zu relations (%zu visible, %zu blocked, %zu degenerate), %.3f s, %.0f relations/s\n",
               o.scene.c_str(), scene->mesh.size(), relations, counts[0], counts[1], counts[2], rel.seconds,
               rel.seconds > 0 ? double(relations) / rel.seconds : 0.0);
  std::vector<std::vector<oracle::RegionAnswer>> regions;
  if (o.regions) {
    auto t0 = std::chrono::steady_clock::now();
    regions.resize(scene->receivers.size());
    ThreadLimit limit(o.threads);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, regions.size(), 1), [&](const tbb::blocked_range<size_t>& rg) {
      for (size_t i = rg.begin(); i < rg.end(); ++i)
        for (size_t l = 0; l < scene->lights.size(); ++l) regions[i].push_back(oracle::visible_region(*scene, i, l));
    });
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "regions: %zu receiver-light pairs, %.3f s\n", regions.size() * scene->lights.size(), secs);
  }
  if (!o.out.empty()) {
    Status st = write_output(o.out, oracle::write_oracle_json(*scene, rel, regions, o.tau));
    if (!st) return bad_input(st.error());
  }
  return kOk;
}
}  // namespace

void add_oracle(CLI::App& app, Action& run) {
  add_command<OracleOpts>(app, run, "oracle", OracleOpts::kHelp, run_oracle);
}

}  // namespace visgate::cli
