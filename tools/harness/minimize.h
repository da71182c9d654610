// The minimiser (`visgate minimize`, DESIGN section 8): shrinks a scene holding one
// mismatching relation to a minimal regression case while the mismatch signature
// (method, direction, family) persists:
//   1. isolate the relation: one receiver, one light whose only sample is the exact
//      sample_position point (explicit_samples with jitter 1); when the method's answer
//      depends on the other relations (it does not reproduce in isolation), every
//      receiver and sample is kept instead and isolation is retried after each round;
//   2. delta debugging (ddmin, Zeller and Hildebrandt 2002) over the blocker triangles;
//   3. shorten float mantissas (every blocker, receiver and sample coordinate, one at a
//      time, to the fewest significant bits that keep the signature);
//   steps 2 and 3 repeat until a round changes nothing, so minimising a minimal case is
//   the identity.
// Only relation mismatches (false-visible, false-blocked) are minimised; the exact side
// is oracle::classify_segment.
#pragma once

#include <optional>
#include <string>

#include "lib/solver.h"
#include "oracle/relation_oracle.h"

namespace visgate::harness {

struct CaseSpec {
  std::string method;
  SolveOptions options;
  size_t receiver = 0, light = 0;
  long sample = 0;
  double tau = 1e-5;
  std::string direction;  // "false-visible" or "false-blocked"; empty: the one found first
};

struct RelationVerdict {
  oracle::RelationClass exact = oracle::RelationClass::Visible;
  double margin = 0.0;
  bool method_visible = false;
  std::string direction;  // "", "false-visible" or "false-blocked" (a mismatch at tau)
};

// The method and the oracle on relation (receiver, light, sample) of `scene`.
Result<RelationVerdict> judge_relation(const Scene& scene, const CaseSpec& spec);

struct MinimizeResult {
  Scene scene;               // normally one receiver, one light, one sample: relation (0, 0, 0)
  size_t receiver = 0, light = 0;  // the relation in `scene` (not (0, 0, 0) only when the
  long sample = 0;                 // mismatch does not reproduce in isolation)
  RelationVerdict verdict;   // on the minimal scene
  size_t triangles_before = 0;
  size_t tests = 0;          // method + oracle evaluations
};

// Errors when the relation is not a mismatch with the requested direction, or when it
// stops being one once isolated (the method's answer depends on other relations).
Result<MinimizeResult> minimize_case(const Scene& scene, const CaseSpec& spec);

// Step 1 alone: the isolated one-receiver, one-sample scene of a relation.
Result<Scene> isolate_relation(const Scene& scene, size_t receiver, size_t light, long sample);

// Fraction mismatches of fragment methods (DESIGN section 5: a visible fraction off by
// more than 1e-4 of the light area) are turned into relation mismatches, which the
// corpus stores: a fraction that far off means the method's fragments are wrong over at
// least that share of the light, so some light point is answered wrongly (the per-sample
// bits of a fragment method come from its fragments). The witness scene is the scene's
// receivers (same indices: with coherence one receiver's fragments depend on the tree the
// others developed) and that light alone, its samples replaced by explicit points of a
// grid x grid lattice over the light's bounding rectangle in its plane (cell centres
// strictly inside the polygon, lifted onto the plane of the first vertex and the Newell
// normal in double, rounded to float).
Result<Scene> light_lattice_scene(const Scene& scene, size_t receiver, size_t light, int grid);

struct FractionWitness {
  Scene scene;       // light_lattice_scene of the pair
  long sample = 0;   // the first lattice point the method answers wrongly (margin >= tau)
  double margin = 0.0;
  std::string direction;  // false-visible or false-blocked
};
// The method on the lattice scene against the relation oracle; nullopt when every lattice
// point is answered correctly (a fraction error on a sliver thinner than the lattice, or a
// fraction computed otherwise than from the fragments).
std::optional<FractionWitness> find_fraction_witness(const Scene& scene, Solver& solver, const SolveOptions& options,
                                                     size_t receiver, size_t light, double tau, int grid = 64);

}  // namespace visgate::harness
