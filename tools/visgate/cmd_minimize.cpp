// visgate minimize scene.json --method M [--receiver I --light L --sample J] [--tau T]
//                  [--opt k=v]... -o DIR
// Minimises one mismatching relation (the given one, the entry's own relation for a
// corpus entry, else the first mismatch found; for a fragment method with no relation
// mismatch but a visible-fraction or fragment mismatch, the first light point of a 64 x 64
// lattice that its fragments answer wrongly, tools/harness/minimize.h FractionWitness;
// the entry's provenance then names the pair with sample -1) and writes the corpus entry
// DIR/<method>/<class>/<sha1>.json (DESIGN section 8). Re-minimising an entry writes the
// identical entry. Exit: 0 stored (or no mismatch to minimise), 2 bad input, 3 internal.
//
// The input may also be a fuzzer crash file of a differential target (fuzz_iss, fuzz_ssv,
// fuzz_plucker, fuzz_embree: anything that is not JSON): it is decoded by the targets'
// own decoder (lib/scene/byte_decoder.h), so the scene and, unless --opt is given, the method
// options are exactly the ones the target ran. Detected by the first byte not being '{';
// --fuzz-input forces it (an input whose selector byte happens to be '{').
#include <cstdio>
#include <filesystem>

#include "lib/scene/byte_decoder.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/scene_json.h"
#include "oracle/comparator.h"
#include "tools/harness/store.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct MinimizeOpts {
  std::string scene, out;
  MethodArgs m;
  long receiver = -1, light = -1, sample = -1;
  double tau = -1;
  bool fuzz_input = false;  // decode as a fuzzer input even if it starts with '{'
  void bind(CLI::App* sub) {
    sub->add_option("scene", scene, "Scene JSON, corpus entry or fuzzer crash file")->required();
    add_method_args(sub, m, {"Method", true, false});
    sub->add_option("--receiver", receiver, "Receiver index of the relation");
    sub->add_option("--light", light, "Light index of the relation");
    sub->add_option("--sample", sample, "Sample index of the relation");
    sub->add_option("--tau", tau, "Margin threshold (default: the entry's, else 1e-5)");
    sub->add_option("-o,--output", out, "Corpus root folder")->required();
    sub->add_flag("--fuzz-input", fuzz_input, "Decode the input as a differential fuzz target's input");
  }
};

uint64_t seed_from_name(const std::string& name) {
  auto dash = name.find_last_of('-');
  if (dash == std::string::npos) return 0;
  try {
    size_t pos = 0;
    uint64_t s = std::stoull(name.substr(dash + 1), &pos);
    return pos == name.size() - dash - 1 ? s : 0;
  } catch (...) {
    return 0;
  }
}

int run_minimize(const MinimizeOpts& o) {
  using namespace visgate::harness;
  auto method = make_method(o.m);
  if (!method) return bad_input(method.error());
  Solver& solver = *method->solver;
  CaseSpec spec;
  spec.method = o.m.method;
  spec.options = method->options;
  int given = (o.receiver >= 0) + (o.light >= 0) + (o.sample >= 0);
  if (given != 0 && given != 3) return bad_input("--receiver, --light and --sample go together");
  ThreadLimit limit(o.m.threads);

  auto text = read_text_file(o.scene);
  if (!text) return bad_input(text.error());
  bool is_entry = text->find("\"case\":") != std::string::npos;
  Scene scene;
  CaseInfo base;
  spec.tau = o.tau >= 0 ? o.tau : 1e-5;
  if (is_entry) {
    auto e = read_corpus_entry(o.scene);
    if (!e) return bad_input(e.error());
    scene = std::move(e->scene);
    if (e->info.method == o.m.method) {
      base = e->info;  // provenance, status and note carry over unchanged
      spec.receiver = e->info.receiver;
      spec.light = e->info.light;
      spec.sample = e->info.sample;
      if (o.tau < 0) spec.tau = e->info.tau;
      spec.direction = e->info.direction;
      if (o.m.opts.empty()) spec.options.opts = e->info.options;
    } else {
      base.family = e->info.family;
      base.seed = e->info.seed;
      base.source_scene = e->info.source_scene;
    }
  } else if (o.fuzz_input || text->find_first_not_of(" \t\r\n") == std::string::npos ||
             (*text)[text->find_first_not_of(" \t\r\n")] != '{') {
    // A fuzzer input: [option selector][scene bytes], decoded as the target did.
    const auto* bytes = reinterpret_cast<const uint8_t*>(text->data());
    auto c = fuzz::decode_case(bytes, text->size(), fuzz::method_limits(o.m.method));
    if (!c) return bad_input(o.scene + ": fuzzer input does not decode: " + c.error().message);
    scene = std::move(c->scene);
    if (o.m.opts.empty()) spec.options.opts = fuzz::decode_options(c->option_selector, solver.options());
    base.family = family_from_scene_name(scene.name);
    base.seed = seed_from_name(scene.name);
    base.source_scene = scene.name + " (fuzzer input " + std::filesystem::path(o.scene).filename().string() + ")";
    base.status = "open";
  } else {
    auto s = read_scene_file(o.scene);
    if (!s) return bad_input(s.error());
    scene = std::move(*s);
    base.family = family_from_scene_name(scene.name);
    base.seed = seed_from_name(scene.name);
    base.source_scene = scene.name;
    base.status = "open";
  }
  if (given == 3) {
    spec.receiver = size_t(o.receiver);
    spec.light = size_t(o.light);
    spec.sample = o.sample;
    spec.direction.clear();
  } else if (!is_entry || base.method.empty()) {
    // The first relation mismatch of the method on the scene.
    SolveResult res = solver.solve(scene, spec.options);
    auto exact = oracle::run_relation_oracle(scene, o.m.threads);
    auto cmp = oracle::compare_relations(scene, res, exact, spec.tau);
    bool found = false;
    for (const auto& m : cmp.mismatches)
      if (m.direction == oracle::Direction::FalseVisible || m.direction == oracle::Direction::FalseBlocked) {
        spec.receiver = m.receiver;
        spec.light = m.light;
        spec.sample = m.sample;
        found = true;
        break;
      }
    // Fragment methods: a visible-fraction or fragment mismatch becomes the relation
    // mismatch of a light point its fragments get wrong (minimize.h FractionWitness).
    if (!found && solver.reports_fragments()) {
      std::vector<size_t> all(scene.receivers.size());
      for (size_t i = 0; i < all.size(); ++i) all[i] = i;
      auto reg = oracle::compare_regions(scene, res, all, spec.tau);
      for (const auto& m : reg.mismatches) {
        auto w = find_fraction_witness(scene, solver, spec.options, m.receiver, m.light, spec.tau);
        if (!w) {
          std::fprintf(stderr, "%s: %s mismatch of receiver %zu light %zu (fraction %.6g, exact %.6g): no lattice point "
                       "of the light is answered wrongly\n", o.scene.c_str(), oracle::direction_name(m.direction),
                       m.receiver, m.light, m.method_fraction, m.exact_fraction);
          continue;
        }
        char note[512];
        std::snprintf(note, sizeof note,
                      "%s: visible fraction %.6g where the exact fraction is %.6g (%s mismatch, receiver %zu light "
                      "%zu of %s, %zu triangles); stored as the %s relation of light point %ld of a 64 x 64 lattice",
                      o.m.method.c_str(), m.method_fraction, m.exact_fraction, oracle::direction_name(m.direction),
                      m.receiver, m.light, base.source_scene.c_str(), scene.mesh.size(), w->direction.c_str(),
                      w->sample);
        if (base.note.empty()) base.note = note;
        base.source_receiver = m.receiver;
        base.source_light = m.light;
        base.source_sample = -1;
        base.source_triangles = scene.mesh.size();
        scene = std::move(w->scene);
        spec.receiver = m.receiver;
        spec.light = 0;
        spec.sample = w->sample;
        spec.direction = w->direction;
        std::fprintf(stderr, "%s: %s mismatch of receiver %zu light %zu: witness light point %ld (%s, margin %.3g)\n",
                     o.scene.c_str(), oracle::direction_name(m.direction), m.receiver, m.light, w->sample,
                     w->direction.c_str(), w->margin);
        found = true;
        break;
      }
    }
    if (!found) {
      std::fprintf(stderr, "%s: no relation mismatch of %s at tau %g: nothing to minimise\n", o.scene.c_str(),
                   o.m.method.c_str(), spec.tau);
      return kOk;
    }
  }
  if (base.method.empty() && base.source_sample >= 0) {
    base.source_receiver = spec.receiver;
    base.source_light = spec.light;
    base.source_sample = spec.sample;
    base.source_triangles = scene.mesh.size();
  }
  auto st = minimize_and_store(scene, spec, base, o.out);
  if (!st) return bad_input(st.error());
  std::error_code ec;
  bool same = std::filesystem::equivalent(st->path, o.scene, ec);
  std::fprintf(stderr, "%s: %s %s, %zu -> %zu triangles, class %s, margin %.3g, %zu tests%s\n", st->path.c_str(),
               o.m.method.c_str(), st->info.direction.c_str(), st->minimized.triangles_before,
               st->minimized.scene.mesh.size(), st->info.class_name.c_str(), st->info.margin, st->minimized.tests,
               same ? " (unchanged: the input is minimal)" : "");
  std::printf("%s\n", st->path.c_str());
  return kOk;
}
}  // namespace

void add_minimize(CLI::App& app, Action& run) {
  add_command<MinimizeOpts>(app, run, "minimize", "Minimise a mismatching relation into a corpus entry", run_minimize);
}

}  // namespace visgate::cli
