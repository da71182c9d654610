// The comparator (DESIGN section 5): turns a method's SolveResult and the oracles'
// answers into mismatches, a histogram of disagreements per margin decade and counts by
// class and direction.
//
// A mismatch is a relation where the method's bit disagrees with a non-degenerate exact
// class and margin >= tau, or, for fragment methods, a receiver/light whose visible
// fraction differs from the exact one by more than 1e-4, or a reported fragment whose
// interior holds a point the relation oracle calls blocked with margin >= tau.
// Disagreements below tau are not mismatches; they are counted per margin decade.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lib/solver.h"
#include "oracle/relation_oracle.h"

namespace visgate::oracle {

enum class Direction { FalseVisible, FalseBlocked, FractionError, FragmentBlocked };
const char* direction_name(Direction d);  // "false-visible", "false-blocked", "fraction", "fragment-blocked"

struct Mismatch {
  size_t receiver = 0, light = 0;
  long sample = -1;            // -1 for fraction and fragment mismatches
  RelationClass exact = RelationClass::Visible;
  bool method_visible = false;
  double margin = 0.0;
  Direction direction = Direction::FalseVisible;
  double exact_fraction = 0.0, method_fraction = 0.0;  // fraction mismatches
};

// Disagreement histogram: bucket k holds margins in [10^(k-12), 10^(k-11)) for k = 0..11
// (1e-12 .. 1), bucket 12 margins >= 1, and `below` margins < 1e-12 (including 0).
struct DecadeHistogram {
  std::array<size_t, 13> buckets{};
  size_t below = 0;
  void add(double margin);
};

// A mismatch's relation, answers and direction name copied into a record type with
// these fields (the check report's MismatchRecord, the public API's Mismatch).
template <class Record>
void copy_mismatch(const Mismatch& m, Record& r) {
  r.receiver = m.receiver;
  r.light = m.light;
  r.sample = m.sample;
  r.exact = char(m.exact);
  r.method_visible = m.method_visible;
  r.margin = m.margin;
  r.direction = direction_name(m.direction);
}

// The counts of a comparison: of one method on one scene (Comparison) or summed over a
// campaign's scenes (the check report's rows, tools/harness/check.h).
struct MismatchCounts {
  size_t relations = 0, degenerate = 0;
  size_t agree = 0, disagree = 0;
  size_t false_visible = 0, false_blocked = 0;  // mismatches (margin >= tau)
  size_t fraction_mismatches = 0, fragment_mismatches = 0;
  size_t mismatch_count() const { return false_visible + false_blocked + fraction_mismatches + fragment_mismatches; }
  void add(const MismatchCounts& o);
};
// The counts as members of `j`, in this order: relations, degenerate, agree, disagree,
// mismatches (given: a check row adds its metamorphic violations), false_visible,
// false_blocked, then the fraction and fragment counts under the names of the format:
// "fraction_mismatches" and "fragment_mismatches" (comparison_json), "fraction" and
// "fragment" (the rows of a check report).
enum class CountNames { Comparison, CheckRow };
void write_counts(nlohmann::ordered_json& j, const MismatchCounts& c, size_t mismatches, CountNames names);

struct Comparison : MismatchCounts {
  DecadeHistogram disagreement_margins;  // every disagreement, any margin
  std::vector<Mismatch> mismatches;
};

// Relation by relation: receivers whose oracle row is empty (not computed) are skipped.
// Degenerate relations count in `degenerate` and nowhere else; every other relation is
// an agreement or a disagreement; a disagreement with margin >= tau is a mismatch
// (false-visible: method says visible, exact class blocked; false-blocked: the reverse).
// The method result must have one row per receiver with enough bits (VG_CHECK).
Comparison compare_relations(const Scene& scene, const SolveResult& method, const RelationOracleResult& exact,
                             double tau);
// For run_relation_oracle_classes: sets the margin of every relation compare_relations
// reads (non-degenerate, answered differently by `method`) from classify_segment, the
// same margin run_relation_oracle gives; the others stay NaN. compare_relations then
// finds exactly what it finds with run_relation_oracle's full result.
void fill_disagreement_margins(const Scene& scene, const SolveResult& method, RelationOracleResult& exact);

// Fragment methods (DESIGN section 5): for each listed receiver and each light, a
// fraction mismatch when |method visible_fraction - exact fraction| > kFractionTolerance
// (region oracle; receivers exactly on a light's plane are skipped), and a fragment
// mismatch for every reported fragment whose interior point (the centroid of its largest
// fan triangle, rounded to float; fragments are convex) the relation oracle calls blocked
// with margin >= tau. Only the fraction/fragment fields of the result are filled.
// `parts` runs one of the two checks alone (fuzz_plucker: the fraction check, the
// expensive one, on a few receivers the input chooses, the fragment check on all): the
// two calls' mismatches together are those of one call with both parts, the fractions'
// first per receiver and light.
inline constexpr double kFractionTolerance = 1e-4;
struct RegionParts {
  bool fractions = true;  // visible fractions against the region oracle
  bool fragments = true;  // one interior point per fragment against the relation oracle
};
Comparison compare_regions(const Scene& scene, const SolveResult& method, const std::vector<size_t>& receivers,
                           double tau, RegionParts parts = {});

// Adds the counts, histogram and mismatches of `other` to `into`.
void merge(Comparison& into, const Comparison& other);

// JSON report: every count, the histogram as {"below_1e-12": n, "decades": [{"from": 1e-12,
// "to": 1e-11, "count": n}, ...], "at_least_1": n}, and at most `max_records` mismatch
// records (receiver, light, sample, exact, method, margin, direction, fractions).
nlohmann::ordered_json comparison_json(const Comparison& c, size_t max_records = 1000);

}  // namespace visgate::oracle
