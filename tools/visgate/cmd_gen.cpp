// visgate gen FAMILY [--seed N] [--triangles N] [--receivers N] [--samples N]
//                    [--light-scale F] [--hex] -o scene.json
#include <cstdio>
#include <memory>

#include "lib/scene/families.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/scene_json.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct GenOpts {
  std::string family, out;
  FamilyParams params;
  bool hex = false;
};

int run_gen(const GenOpts& o) {
  auto scene = generate_family(o.family, o.params);
  if (!scene) return bad_input(scene.error().message);
  std::string text = write_scene_json(*scene, SceneWriteOptions{o.hex});
  if (o.out == "-") {
    std::fwrite(text.data(), 1, text.size(), stdout);
  } else {
    Status st = write_file_atomic(o.out, text);
    if (!st) return bad_input(st.error().message);
  }
  std::fprintf(stderr, "%s: %zu triangles, %zu lights, %zu receivers, %zu relations\n", scene->name.c_str(),
               scene->mesh.size(), scene->lights.size(), scene->receivers.size(), scene->relation_count());
  return kOk;
}
}  // namespace

void add_gen(CLI::App& app, Action& run) {
  auto o = std::make_shared<GenOpts>();
  auto* sub = app.add_subcommand("gen", "Generate a scene of a family (deterministic by seed)");
  sub->add_option("family", o->family, "Scene family")->required();
  sub->add_option("--seed", o->params.seed, "Seed");
  sub->add_option("--triangles", o->params.triangles, "Target blocker triangle count");
  sub->add_option("--receivers", o->params.receivers, "Receiver count");
  sub->add_option("--samples", o->params.samples, "Samples per light");
  sub->add_option("--light-scale", o->params.light_scale, "Scale every light polygon about its centre");
  sub->add_option("--scale-exponent", o->params.scale_exponent,
                  "Multiply the generated scene by 2^K (clamped to where the copy is exact)");
  sub->add_flag("--hex", o->hex, "Write coordinates as C99 hex-floats");
  sub->add_option("-o,--output", o->out, "Output scene JSON ('-' for stdout)")->required();
  sub->callback([o, &run] { run = [o] { return run_gen(*o); }; });
}

}  // namespace visgate::cli
