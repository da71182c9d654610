// visgate's public C++ API (namespace visgate::api): exact visibility answers and
// validation for a renderer's or a tool's own code, without JSON or the CLI.
//
//   find_package(visgate REQUIRED)
//   target_link_libraries(app PRIVATE visgate::oracle)   # scene + methods + oracle
//
// Targets: visgate::scene (scenes: build from arrays, read, generate families),
// visgate::methods (solve with a named method: the built-ins of DESIGN section 4 and
// exec:CMD / plugin:PATH), visgate::oracle (exact classes, margins, regions and the
// comparison of a solution with them; links the other two), visgate::repair (mesh repair,
// exact). Each section below names the target that provides it.
//
// Semantics are DESIGN's (../shared/DESIGN.md sections 3 to 5): relation (i, b) of
// receiver i is bit b of its light-major relation list (light l's samples are bits
// [relation_offset(l), relation_offset(l + 1))); V = 1 iff no triangle meets the open
// segment from the receiver to the relation's light point; the oracle's classes are
// 'v' visible, 'b' blocked (a proper crossing), 'd' degenerate (only a touch).
//
// Errors are values: every function that can fail on its input returns Outcome<T>,
// whose error() is one line naming the element (as the CLI prints it). A failure of an
// external method (crash, timeout, malformed result) is an error too. Nothing here prints
// or exits. Names in this header are stable; additions only.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace visgate {
struct Scene;  // the library's scene (lib/scene/scene.h), behind api::Scene
}

namespace visgate::api {

inline constexpr const char* kVersion = "0.1.0";

struct Vec3 {
  float x = 0, y = 0, z = 0;
  friend bool operator==(const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
};
using Polygon = std::vector<Vec3>;

// A value or a one-line error.
template <class T>
class Outcome {
 public:
  Outcome(T value) : value_(std::move(value)) {}
  static Outcome failure(std::string message) {
    Outcome o;
    o.error_ = std::move(message);
    return o;
  }
  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const std::string& error() const { return error_; }
  T& value() { return *value_; }
  const T& value() const { return *value_; }
  T& operator*() { return *value_; }
  const T& operator*() const { return *value_; }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }

 private:
  Outcome() = default;
  std::optional<T> value_;
  std::string error_;
};

// ---- scenes (visgate::scene) -------------------------------------------------------------

enum class Pattern { Stratified, Random, Grid, Explicit };

struct LightDesc {
  Polygon polygon;        // planar, convex, counter-clockwise seen from the lit side
  int samples = 16;       // N
  Pattern pattern = Pattern::Stratified;
  int jitter = 4;         // K jitter points per sample (1 with explicit samples)
  uint64_t seed = 1;
  std::vector<Vec3> explicit_samples;  // with Pattern::Explicit: sample j is exactly explicit_samples[j]
};

struct ReceiverDesc {
  Vec3 p;
  Vec3 n{0, 0, 1};
};

struct SceneDesc {
  std::string name = "api";
  std::vector<float> vertices;      // blockers: x, y, z per vertex
  std::vector<uint32_t> triangles;  // three vertex indices per triangle (a soup: nothing welded)
  std::vector<LightDesc> lights;
  std::vector<ReceiverDesc> receivers;
};

// An immutable, validated scene; cheap to copy (shared).
class Scene {
 public:
  const std::string& name() const;
  size_t triangle_count() const;
  size_t receiver_count() const;
  size_t light_count() const;
  size_t relations_per_receiver() const;  // sum of the lights' sample counts
  size_t relation_count() const { return receiver_count() * relations_per_receiver(); }
  size_t relation_offset(size_t light) const;  // first bit of light `light`
  Vec3 receiver(size_t i) const;
  // The light point of relation (receiver i, bit b): DESIGN's sample_position.
  Vec3 light_point(size_t i, size_t b) const;
  // Triangle t's corners.
  std::array<Vec3, 3> triangle(size_t t) const;
  // Scene JSON (format "visgate-scene"), self-contained, bit-exact.
  std::string to_json() const;

  // A scene of the one relation (receiver i, bit b): that receiver, a one-sample explicit
  // light at its light point, the same triangles. Answers of the relation carry over
  // exactly for methods that answer scenes as given (oracle, baselines, external methods).
  Scene single_relation(size_t i, size_t b) const;
  // The scene keeping only the triangles with keep[t] (keep.size() == triangle_count()) and
  // the vertices they use.
  Scene with_triangles(const std::vector<bool>& keep) const;

  const visgate::Scene& impl() const { return *impl_; }  // for the library's own use
  explicit Scene(std::shared_ptr<const visgate::Scene> s) : impl_(std::move(s)) {}

 private:
  std::shared_ptr<const visgate::Scene> impl_;
};

// Validates and builds (NaN/Inf, indices, light planarity and convexity, sample counts).
Outcome<Scene> make_scene(const SceneDesc& desc);
// Reads a scene JSON file (DESIGN section 6; mesh files relative to it).
Outcome<Scene> read_scene(const std::string& path);
// A generated scene of a family (DESIGN section 7's list); parameters < 0: the default.
std::vector<std::string> family_names();
Outcome<Scene> generate_family(const std::string& family, uint64_t seed, long triangles = -1, long receivers = -1,
                               long samples = -1);

// ---- methods (visgate::methods) ----------------------------------------------------------

struct SolveSettings {
  std::map<std::string, std::string> options;  // `--opt key=value`
  int threads = 0;                             // 0: all hardware threads
  uint64_t seed = 1;
};

struct Solution {
  std::string method;
  size_t receivers = 0, relations_per_receiver = 0, lights = 0;
  std::vector<uint8_t> visible;          // receiver-major, 1 visible / 0 blocked
  std::vector<float> visible_fraction;   // receiver-major, one per light
  // Fragment methods (plucker-bsp): fragments[i][l] are the visible light polygons of
  // receiver i and light l; empty otherwise.
  std::vector<std::vector<std::vector<Polygon>>> fragments;
  std::map<std::string, double> stats;
  double seconds = 0.0;  // the method's own wall time (DESIGN section 4)

  bool is_visible(size_t i, size_t b) const { return visible[i * relations_per_receiver + b] != 0; }
  float fraction(size_t i, size_t light) const { return visible_fraction[i * lights + light]; }
};

// The built-in method names (exec:CMD and plugin:PATH are accepted as well).
std::vector<std::string> method_names();
// Solves every relation. Errors: unknown method or option, a plugin that cannot be
// loaded, an external method's failure.
Outcome<Solution> solve(const Scene& scene, const std::string& method, const SolveSettings& settings = {});

// ---- the exact oracle (visgate::oracle) --------------------------------------------------

struct Classes {
  size_t receivers = 0, relations_per_receiver = 0;
  std::vector<char> cls;        // receiver-major: 'v', 'b' or 'd'
  std::vector<double> margins;  // parallel; 0 for 'd' (DESIGN section 5)
  double seconds = 0.0;
  char at(size_t i, size_t b) const { return cls[i * relations_per_receiver + b]; }
  double margin(size_t i, size_t b) const { return margins[i * relations_per_receiver + b]; }
};
// Exact class and margin of every relation.
Classes classify(const Scene& scene, int threads = 0);

struct Region {
  double visible_fraction = 0.0;  // exact area fraction, rounded to double
  std::vector<Polygon> polygons;  // the visible part of the light, on its plane (rounded to float)
};
// The exact visible region of light `light` seen from receiver i.
Outcome<Region> visible_region(const Scene& scene, size_t receiver, size_t light);

struct Mismatch {
  size_t receiver = 0, light = 0;
  long sample = -1;      // -1 for fraction and fragment mismatches
  char exact = 'v';
  bool method_visible = false;
  double margin = 0.0;
  std::string direction;  // "false-visible", "false-blocked", "fraction", "fragment-blocked"
};
struct Comparison {
  size_t relations = 0, degenerate = 0, agree = 0, disagree = 0;
  size_t false_visible = 0, false_blocked = 0, fraction = 0, fragment = 0;
  std::vector<Mismatch> mismatches;  // up to 1000
  size_t mismatch_count() const { return false_visible + false_blocked + fraction + fragment; }
};
// A solution against the exact answers (DESIGN section 5): relation mismatches with
// margin >= tau, and for solutions with fragments the region checks on every receiver.
Outcome<Comparison> compare(const Scene& scene, const Solution& solution, double tau = 1e-5, int threads = 0);

// ---- repair (visgate::repair) ------------------------------------------------------------

struct RepairSettings {
  double weld_tolerance = 0.0;  // weld vertices within this distance (exact test)
  size_t fill_holes = 0;        // fill boundary loops of at most this many edges
};
struct RepairedMesh {
  std::vector<double> vertices;     // x, y, z (input coordinates, never moved)
  std::vector<uint32_t> triangles;  // three indices per triangle
  size_t welded_vertices = 0, removed_triangles = 0;
  size_t defects_before = 0, defects_after = 0;  // DESIGN's defect counts, summed
};
// `visgate repair` on arrays of polygons (faces[f] lists vertex indices).
Outcome<RepairedMesh> repair(const std::vector<double>& vertices, const std::vector<std::vector<uint32_t>>& faces,
                             const RepairSettings& settings = {});

}  // namespace visgate::api
