// visgate render scene.json (--method M | --oracle [--exact-region]) [--diff] [--opt k=v]...
//                [--threads N] [--tau T] [--scale K] -o image.png
// The receiver grid as an image (PNG through stb_image_write), one pixel block per
// receiver, +v up, the fraction in the viridis colour map with its legend, a scale bar
// and the lights' outlines (tools/bench/image.h render_picture):
//   --method M       M's visible fraction, summed over lights and divided by their count;
//   --oracle         the same from the exact relation oracle (a degenerate relation
//                    counts one half); with --exact-region the region oracle's exact
//                    area fraction instead of the sampled relations;
//   --diff           (with --method) M's fraction with a mark on each receiver where M
//                    disagrees with the relation oracle: red = a mismatch (margin >=
//                    tau), orange = only disagreements below tau.
// Exit 2 when the scene has no receiver grid.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstdio>

#include "lib/scene/scene_json.h"
#include "lib/solver.h"
#include "oracle/comparator.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tools/bench/image.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct RenderOpts {
  static constexpr const char* kHelp = "Draw the receiver grid: visible fraction, exact fraction or a diff (PNG)";
  std::string scene, out;
  MethodArgs m;
  bool oracle = false, exact_region = false, diff = false;
  int scale = 0;
  double tau = 1e-5;
  void bind(CLI::App* sub) {
    sub->add_option("scene", scene, "Scene JSON with a receiver grid")->required();
    add_method_args(sub, m, {"Method to draw (or to compare with --diff)", false, true});
    sub->add_flag("--oracle", oracle, "Draw the exact relation-oracle fraction");
    sub->add_flag("--exact-region", exact_region, "With --oracle: the region oracle's exact area fraction");
    sub->add_flag("--diff", diff, "Heat map of where --method disagrees with the oracle");
    sub->add_option("--tau", tau, "Mismatch margin threshold for --diff (default 1e-5)");
    sub->add_option("--scale", scale, "Pixels per receiver (0: at least 512 pixels wide)");
    sub->add_option("-o,--output", out, "Output PNG")->required();
  }
};

int run_render(const RenderOpts& o) {
  if (o.m.method.empty() && !o.oracle) return bad_input("render: give --method M, --oracle, or --method M --diff");
  if (o.diff && o.m.method.empty()) return bad_input("render: --diff needs --method");
  if (o.diff && o.oracle) return bad_input("render: --diff and --oracle exclude each other");
  if (o.exact_region && !o.oracle) return bad_input("render: --exact-region needs --oracle");
  if (o.scale < 0) return bad_input("render: --scale " + std::to_string(o.scale) + ": expected 0 (auto) or more");
  if (!(o.tau >= 0)) return bad_input("render: --tau: expected a non-negative margin");

  Method method;
  if (!o.m.method.empty() && !o.oracle) {
    auto made = make_method(o.m);
    if (!made) return bad_input(made.error());
    method = std::move(*made);
  }
  auto scene = read_scene_file(o.scene);
  if (!scene) return bad_input(scene.error());
  const Scene& s = *scene;
  if (!s.grid)
    return bad_input(o.scene + ": receivers: the scene has no receiver grid (render draws \"receivers\": {\"grid\": ...})");
  const ReceiverGrid& g = *s.grid;
  if (size_t(g.nu) * size_t(g.nv) != s.receivers.size())
    return bad_input(o.scene + ": receivers.grid: nu*nv does not match the receiver count");
  int scale = o.scale > 0 ? o.scale : bench::auto_scale(g);

  bench::Picture pic;
  for (const Light& l : s.lights) pic.lights.push_back(l.polygon);
  if (o.oracle && o.exact_region) {
    size_t L = s.lights.size(), n = s.receivers.size() * L;
    std::vector<double> f(n);
    ThreadLimit limit(o.m.threads);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) f[k] = oracle::visible_region(s, k / L, k % L).visible_fraction;
    });
    pic.fraction.resize(s.receivers.size());
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      double sum = 0;
      for (size_t l = 0; l < L; ++l) sum += f[i * L + l];
      pic.fraction[i] = L ? sum / double(L) : 0.0;
    }
    std::fprintf(stderr, "render %s: exact region fraction, %zu receivers x %zu lights\n", o.scene.c_str(),
                 s.receivers.size(), L);
  } else if (o.oracle) {
    auto exact = oracle::run_relation_oracle(s, o.m.threads);
    pic.fraction = bench::mean_class_fraction(s, exact.classes);
    std::fprintf(stderr, "render %s: relation oracle fraction, %zu relations, %.3f s\n", o.scene.c_str(),
                 s.relation_count(), exact.seconds);
  } else {
    SolveResult result = method.solver->solve(s, method.options);
    pic.fraction = bench::mean_visible_fraction(s, result);
    if (!o.diff) {
      std::fprintf(stderr, "render %s: %s visible fraction, %.3f s\n", o.scene.c_str(), o.m.method.c_str(),
                   result.seconds);
    } else {
      auto exact = oracle::run_relation_oracle(s, o.m.threads);
      pic.diff = bench::diff_receivers(s, result, exact.classes, exact.margins, o.tau);
      // Fraction and fragment mismatches of fragment methods (DESIGN section 5) mark
      // their receivers too.
      auto cmp = oracle::compare_relations(s, result, exact, o.tau);
      for (const auto& m : cmp.mismatches)
        if (m.sample < 0 && m.receiver < pic.diff.size()) ++pic.diff[m.receiver].mismatches;
      size_t mis_rec = 0, below_rec = 0, mis = 0, below = 0;
      for (const auto& d : pic.diff) {
        mis += d.mismatches, below += d.below_tau;
        mis_rec += d.mismatches > 0;
        below_rec += d.mismatches == 0 && d.below_tau > 0;
      }
      std::fprintf(stderr,
                   "render %s: %s against the relation oracle (tau %g): %zu mismatches at %zu receivers (red), "
                   "%zu disagreements below tau at %zu more receivers (orange)\n",
                   o.scene.c_str(), o.m.method.c_str(), o.tau, mis, mis_rec, below, below_rec);
    }
  }
  if (Status ws = bench::write_png(o.out, bench::render_picture(g, pic, scale)); !ws) return bad_input(ws.error());
  return kOk;
}
}  // namespace

void add_render(CLI::App& app, Action& run) {
  add_command<RenderOpts>(app, run, "render", RenderOpts::kHelp, run_render);
}

}  // namespace visgate::cli
