// The differential check (DESIGN sections 5 and 7, `visgate check`): runs methods and
// the exact relation oracle on scenes, compares them with oracle::compare_relations,
// runs the metamorphic checks, and accumulates a report per (family, method) with a
// disagreement histogram per margin decade. Reports are JSON (format
// "visgate-check-report") so that shards of one campaign can be merged.
//
// Metamorphic checks (lib/scene/exact_transform.h), per scene and method:
//   scale      every coordinate multiplied by 2^k, two exponents per scene spread over
//              [-120, 124] (one negative, one positive, picked by the scene's name and
//              clamped to the range where the copy is exact): the production methods
//              solve the same unit copy, so every bit and every visible fraction must be
//              unchanged; any change is a violation (the baselines, which answer scenes
//              as given, are counted too but never fail the gate).
//   axes       an exact axis permutation with mirrors (one of the 47 non-identity maps,
//              picked by the scene's name): the oracle's classes must be unchanged (a
//              violation is reported for the method "oracle") and a method's bit may
//              change only on relations whose margin is below tau.
//   translate  an offset per axis chosen so that every coordinate (blockers, light
//              polygons, light points, receivers) translates exactly in float32: the
//              same rules as axes.
// Violations are mismatches of class "metamorphic".
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lib/scene/exact_transform.h"
#include "lib/scene/families.h"
#include "lib/solver.h"
#include "oracle/comparator.h"

namespace visgate::harness {

struct MethodSpec {
  std::string name;  // the registered method
  SolveOptions options;
  // The row this spec's results go to: `name`, or NAME#TAG when one method runs with
  // several option sets (the gate's iss#shafts).
  std::string label;
  const std::string& row() const { return label.empty() ? name : label; }
};
// The method of a row label: NAME for NAME#TAG.
std::string method_of_label(const std::string& label);

// Margin decades as in oracle::DecadeHistogram: index 0 is "below 1e-12" (and 0),
// index k + 1 the bucket k = [10^(k-12), 10^(k-11)), index 13 margins >= 1.
inline constexpr size_t kDecades = 14;
using DecadeCounts = std::array<size_t, kDecades>;
void add_histogram(DecadeCounts& into, const oracle::DecadeHistogram& h);
// Label of decade index d ("<1e-12", "1e-12", ..., "1e-1", ">=1").
std::string decade_label(size_t d);

struct MismatchRecord {
  std::string method;
  std::map<std::string, std::string> options;
  std::string family, scene, scene_file;  // scene_file empty for generated scenes
  uint64_t seed = 0;
  FamilyParams params;                    // generation parameters (generated scenes)
  size_t receiver = 0, light = 0;
  long sample = -1;
  char exact = 'v';                        // 'v', 'b' or 'd'
  bool method_visible = false;
  double margin = 0.0;
  std::string direction;  // false-visible, false-blocked, fraction, fragment-blocked, or for
                          // metamorphic records: scale 2^k, axes, translate
  std::string kind;       // "oracle" (against the exact answer) or "metamorphic"
  std::string stored;     // corpus path when --store kept a case for it
};

// One row of the table: a (family, method) pair over every scene of the family; its
// comparison counts summed over the scenes, plus the metamorphic violations.
struct Row : oracle::MismatchCounts {
  size_t scenes = 0, metamorphic = 0;
  // Relations a method decided by its own geometry rather than by rays, where it says
  // (iss: stats relations_blocked_by_shaft + relations_visible_by_empty_shaft), and the
  // relations of the scenes that reported it.
  size_t shaft_decided = 0, shaft_reported = 0;
  DecadeCounts disagreements{};  // every disagreement (any margin) per margin decade
  DecadeCounts relations_per_decade{};  // non-degenerate relations per margin decade
  double seconds = 0.0;
  size_t mismatches() const { return mismatch_count() + metamorphic; }
  void merge(const Row& o);
};

struct SceneSummary {
  std::string name, family, file;
  uint64_t seed = 0;
  size_t triangles = 0, relations = 0;
  double oracle_seconds = 0.0;
};

struct CheckReport {
  double tau = 1e-5;
  std::vector<std::string> methods;
  std::vector<std::string> shards;  // "k/N" of every merged part ("1/1" for a whole run)
  std::map<std::pair<std::string, std::string>, Row> rows;  // (family, method)
  std::vector<SceneSummary> scenes;
  std::vector<MismatchRecord> mismatches;  // at most kMaxRecords per (scene, method, kind)
  std::vector<std::string> errors;         // methods that threw, minimisations that failed
  size_t mismatch_count() const;           // over every row
  size_t mismatch_count(const std::string& method) const;
};

inline constexpr size_t kMaxRecords = 64;

struct CheckConfig {
  std::vector<MethodSpec> methods;
  double tau = 1e-5;
  int threads = 0;
  bool metamorphic = true;
  // Scale exponents of the metamorphic scale check; empty: two per scene from the
  // spread over [-120, 124] (metamorphic_scale_exponents).
  std::vector<int> scale_exponents;
  // Fragment methods (plucker-bsp): visible fractions against the region oracle and one
  // interior point per fragment against the relation oracle (oracle::compare_regions,
  // DESIGN section 5), on at most this many (receiver, light) pairs per scene: every
  // receiver when receivers x lights fits, else every k-th receiver. 0: none.
  size_t region_pairs = 4096;
};

// Where a scene came from (for records and minimisation provenance).
struct SceneOrigin {
  std::string family;  // family name, or "file" for scene files
  uint64_t seed = 0;
  FamilyParams params;
  std::string file;
};

// The metamorphic scale exponents of a scene without CheckConfig::scale_exponents: one
// of -120, -96, -64, -48, -40, -32, -16 and one of 16, 32, 48, 64, 96, 124, picked by
// `key`, each clamped to `range` (dropped when that leaves 0).
std::vector<int> metamorphic_scale_exponents(uint64_t key, const ScaleRange& range);

// Checks one scene and adds its rows, summary and mismatch records to `report`.
void check_scene(const Scene& scene, const SceneOrigin& origin, const CheckConfig& cfg, CheckReport& report);

// Shards: "k/N" with 1 <= k <= N; job i belongs to shard k iff i mod N == k - 1.
Result<std::pair<int, int>> parse_shard(const std::string& text);

// Report JSON and merging.
std::string report_to_json(const CheckReport& r);
Result<CheckReport> report_from_json(const std::string& text, const std::string& origin);
// Merges `other` into `into`; tau and methods must agree.
Status merge_report(CheckReport& into, const CheckReport& other);
// The human table (per family and method: relations, mismatches, disagreements below
// tau per margin decade, seconds).
std::string format_table(const CheckReport& r);

}  // namespace visgate::harness
