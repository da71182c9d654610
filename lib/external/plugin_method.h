// `plugin:PATH` methods (DESIGN section 4, include/visgate/plugin.h,
// docs/external-methods.md): a visibility method in a shared library, run in-process.
//
// The library is loaded once per path for the process (dlopen, RTLD_NOW | RTLD_LOCAL) and
// never unloaded. Each solve hands the plugin the scene as flat arrays (built once per
// solve; the light point of every relation unless the plugin opts out) and visgate-owned
// output buffers, then checks the answer's shape (fractions in [0, 1] or NaN).
//
// Failures: a load error, a missing or wrong-version descriptor, an error status, or a
// crash throws ExternalMethodError naming the method. With `guard` (the default) a
// synchronous signal on the calling thread (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT,
// SIGTRAP) during the plugin's solve returns to visgate through siglongjmp on an
// alternate stack; the library is then marked crashed and every later solve of it fails
// at once (its state may be corrupt). A crash on a thread the plugin started, or memory
// corruption that only shows later, is not caught: for full isolation use exec:. The
// fuzz target fuzz_plugin turns the guard off so that the sanitizers see the crash.
//
// seconds: wall time of building the flat arrays, the plugin's solve and the copy of its
// bits (the built-in methods' seconds include their own setup the same way).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "include/visgate/plugin.h"
#include "lib/external/exec_method.h"
#include "lib/solver.h"

namespace visgate::external {

struct LoadedPlugin;  // one per library path, process-wide

class PluginSolver final : public Solver {
 public:
  // Loads `path` (or finds it loaded); throws ExternalMethodError when it cannot.
  explicit PluginSolver(std::string path, bool guard = true);
  ~PluginSolver() override;
  std::string name() const override { return "plugin:" + path_; }
  std::vector<OptionSpec> options() const override;
  bool normalises_scale() const override { return false; }  // answers the scene as given

 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;

 private:
  std::string path_;
  bool guard_;
  LoadedPlugin* lib_ = nullptr;
  void* state_ = nullptr;             // from the plugin's create, made at the first solve
  std::map<std::string, std::string> state_opts_;  // the options state_ was made with
  bool has_state_ = false;
};

// The flat arrays of a scene (visgate_scene_v1_t) and the storage behind them.
struct FlatScene {
  visgate_scene_v1_t view{};
  std::vector<float> vertices, receiver_points, receiver_normals, light_polygons, jitter_points, relation_points;
  std::vector<uint32_t> triangles, light_jitter, light_pattern;
  std::vector<uint64_t> light_polygon_offsets, light_offsets, light_seed;
};
void flatten_scene(const Scene& scene, bool relation_points, FlatScene& out);

}  // namespace visgate::external
