// visgate gen FAMILY [--seed N] [--triangles N] [--receivers N] [--samples N]
//                    [--light-scale F] [--hex] -o scene.json
#include <cstdio>

#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct GenOpts {
  std::string family, out;
  FamilyParams params;
  bool hex = false;
  void bind(CLI::App* sub) {
    sub->add_option("family", family, "Scene family")->required();
    sub->add_option("--seed", params.seed, "Seed");
    add_family_args(sub, params);
    sub->add_flag("--hex", hex, "Write coordinates as C99 hex-floats");
    sub->add_option("-o,--output", out, "Output scene JSON ('-' for stdout)")->required();
  }
};

int run_gen(const GenOpts& o) {
  auto scene = generate_family(o.family, o.params);
  if (!scene) return bad_input(scene.error());
  if (Status st = write_output(o.out, write_scene_json(*scene, SceneWriteOptions{o.hex})); !st) return bad_input(st.error());
  std::fprintf(stderr, "%s: %zu triangles, %zu lights, %zu receivers, %zu relations\n", scene->name.c_str(),
               scene->mesh.size(), scene->lights.size(), scene->receivers.size(), scene->relation_count());
  return kOk;
}
}  // namespace

void add_gen(CLI::App& app, Action& run) {
  add_command<GenOpts>(app, run, "gen", "Generate a scene of a family (deterministic by seed)", run_gen);
}

}  // namespace visgate::cli
