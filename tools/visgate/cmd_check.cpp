// visgate check (scene.json... | --family F --count N --seed S) --methods M1,M2 [--tau T]
//               [--report r.json] [--store DIR] [--shard k/N] [--threads N]
//               [--triangles N] [--receivers N] [--samples N] [--light-scale F]
//               [--opt M:key=value]... [--no-metamorphic] [--region-pairs N]
// Runs methods and the exact oracle, compares (DESIGN section 5; fragment methods also
// against the region oracle on up to N receiver-light pairs per scene), prints a table per
// family and method on stderr, writes the report JSON, and with --store minimises and
// stores one corpus case per distinct mismatch signature (method, direction, family).
// Exit: 0 no mismatch, 1 mismatches, 2 bad input, 3 a method threw.
#include <cstdio>
#include <map>
#include <set>
#include <tuple>

#include "lib/scene/families.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/scene_json.h"
#include "tools/harness/check.h"
#include "tools/harness/store.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct CheckOpts {
  static constexpr const char* kHelp = "Compare methods with the exact oracle on scenes or generated families";
  std::vector<std::string> scenes, opts;
  std::string family, methods, report, store, shard = "1/1";
  long count = 1;
  uint64_t seed = 1;
  FamilyParams params;
  double tau = 1e-5;
  int threads = 0;
  uint64_t memory_budget_mb = 0;
  bool no_metamorphic = false;
  std::vector<int> scale_exponents;
  size_t region_pairs = 4096;
  void bind(CLI::App* sub) {
    sub->add_option("scenes", scenes, "Scene JSON files");
    sub->add_option("--family", family, "Family (comma list, or 'all') to generate scenes from");
    sub->add_option("--count", count, "Scenes per family (seeds S, S+1, ...)");
    sub->add_option("--seed", seed, "First seed");
    add_family_args(sub, params);  // of the generated scenes
    sub->add_option("--methods", methods,
                    "Methods, comma-separated, or 'all'; NAME#TAG runs NAME again in a row of its own with the options "
                    "given to NAME#TAG")->required();
    sub->add_option("--opt", opts, "Method option METHOD:key=value (repeatable; METHOD may be NAME#TAG)");
    sub->add_option("--tau", tau, "Margin threshold: disagreements below it are not mismatches (default 1e-5)");
    sub->add_option("--report", report, "Write the report JSON here");
    sub->add_option("--store", store, "Minimise and store one corpus case per mismatch signature under DIR");
    sub->add_option("--shard", shard, "Run shard k of N (1 <= k <= N) of the campaign");
    sub->add_option("--threads", threads, "Threads (0: all)");
    sub->add_option("--memory-budget", memory_budget_mb,
                    "MB each method's growing structures may hold (0, the default: half of physical memory, at most 8192)");
    sub->add_flag("--no-metamorphic", no_metamorphic, "Skip the scale, axis-map and translation checks");
    sub->add_option("--scale-exponents", scale_exponents,
                    "Metamorphic scale exponents k (2^k copies), comma-separated; default two per scene spread "
                    "over [-120, 124]")->delimiter(',');
    sub->add_option("--region-pairs", region_pairs,
                    "Fragment methods: receiver-light pairs per scene checked against the region oracle "
                    "(fractions, fragments); every k-th receiver when more (default 4096, 0: none)");
  }
};

int run_check(const CheckOpts& o) {
  using namespace visgate::harness;
  if (o.scenes.empty() == o.family.empty())
    return bad_input("check: give scene files or --family (not both)");
  if (!(o.tau >= 0)) return bad_input("--tau: must be a non-negative number");
  if (o.count < 1) return bad_input("--count: must be at least 1");
  auto shard = parse_shard(o.shard);
  if (!shard) return bad_input(shard.error());
  CheckConfig cfg;
  cfg.tau = o.tau;
  cfg.threads = o.threads;
  cfg.metamorphic = !o.no_metamorphic;
  cfg.scale_exponents = o.scale_exponents;
  cfg.region_pairs = o.region_pairs;
  auto names = solver_names();
  std::vector<std::string> methods = o.methods == "all" ? names : split_list(o.methods);
  if (methods.empty()) return bad_input("--methods: empty list");
  for (const auto& m : methods) {
    auto spec = method_spec(m, o.opts, o.threads, "--methods");
    if (!spec) return bad_input(spec.error());
    spec->options.memory_budget_mb = o.memory_budget_mb;  // past it the method throws: exit 3
    cfg.methods.push_back(*spec);
  }
  std::vector<std::string> families;
  if (!o.family.empty()) {
    families = o.family == "all" ? family_names() : split_list(o.family);
    for (const auto& f : families)
      if (!is_family(f)) return bad_input("--family " + f + ": unknown family");
  }

  CheckReport report;
  report.tau = o.tau;
  report.methods = methods;
  report.shards = {o.shard};
  ThreadLimit limit(o.threads);
  std::set<std::tuple<std::string, std::string, std::string>> stored_signatures;
  // Minimisation attempts per signature: a signature whose first records do not
  // minimise (the method's answer changes with the scene) is given up after three.
  std::map<std::tuple<std::string, std::string, std::string>, int> attempts;

  // The campaign: files in order, or families x count seeds; job i is in shard k iff
  // i mod N == k - 1.
  size_t jobs = o.scenes.empty() ? families.size() * size_t(o.count) : o.scenes.size();
  for (size_t job = 0; job < jobs; ++job) {
    if (job % size_t(shard->second) != size_t(shard->first - 1)) continue;
    SceneOrigin origin;
    Result<Scene> scene = Error{""};
    if (!o.scenes.empty()) {
      origin.file = o.scenes[job];
      scene = read_scene_file(origin.file);
      if (!scene) return bad_input(scene.error());
      origin.family = family_from_scene_name(scene->name);
    } else {
      origin.family = families[job / size_t(o.count)];
      origin.seed = o.seed + job % size_t(o.count);
      origin.params = o.params;
      origin.params.seed = origin.seed;
      scene = generate_family(origin.family, origin.params);
      if (!scene) return bad_input(scene.error());
    }
    size_t first_record = report.mismatches.size();
    check_scene(*scene, origin, cfg, report);
    if (stderr_is_tty())
      std::fprintf(stderr, "[%zu/%zu] %s: %zu relations, %zu mismatch records so far\n", job + 1, jobs,
                   scene->name.c_str(), scene->relation_count(), report.mismatches.size());
    if (o.store.empty()) continue;
    for (size_t r = first_record; r < report.mismatches.size(); ++r) {
      MismatchRecord& rec = report.mismatches[r];
      if (rec.kind != "oracle" || (rec.direction != "false-visible" && rec.direction != "false-blocked")) continue;
      auto sig = std::make_tuple(rec.method, rec.direction, rec.family);
      if (stored_signatures.count(sig) || attempts[sig] >= 3) continue;
      ++attempts[sig];
      CaseSpec spec;
      spec.method = rec.method;
      spec.options.opts = rec.options;
      spec.options.threads = o.threads;
      spec.receiver = rec.receiver;
      spec.light = rec.light;
      spec.sample = rec.sample;
      spec.tau = o.tau;
      spec.direction = rec.direction;
      CaseInfo base;
      base.family = rec.family;
      base.seed = rec.seed;
      base.source_scene = scene->name;
      base.source_receiver = rec.receiver;
      base.source_light = rec.light;
      base.source_sample = rec.sample;
      base.source_triangles = scene->mesh.size();
      base.status = "open";
      auto st = minimize_and_store(*scene, spec, base, o.store);
      if (!st) {
        if (attempts[sig] == 3) report.errors.push_back("store: " + st.error().message + " (given up after 3 records)");
        continue;  // try the next record of this signature
      }
      stored_signatures.insert(sig);
      rec.stored = st->path;
      std::fprintf(stderr, "stored %s (%zu -> %zu triangles, %zu tests)\n", st->path.c_str(),
                   st->minimized.triangles_before, st->minimized.scene.mesh.size(), st->minimized.tests);
    }
  }
  std::fputs(format_table(report).c_str(), stderr);
  for (const auto& e : report.errors) std::fprintf(stderr, "error: %s\n", e.c_str());
  if (!o.report.empty()) {
    if (Status st = write_file_atomic(o.report, report_to_json(report)); !st) return bad_input(st.error());
  }
  bool threw = false;
  for (const auto& e : report.errors) threw |= e.find(" threw: ") != std::string::npos;
  if (threw) return kInternal;
  return report.mismatch_count() > 0 ? kFound : kOk;
}
}  // namespace

void add_check(CLI::App& app, Action& run) { add_command<CheckOpts>(app, run, "check", CheckOpts::kHelp, run_check); }

}  // namespace visgate::cli
