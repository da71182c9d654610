// `exec:CMD` methods (DESIGN section 4, docs/external-methods.md): a visibility method in
// any language, run as a program once per scene.
//
// visgate writes the scene to a temporary folder in the explicit form below, runs
// `/bin/sh -c 'CMD "$@"' sh SCENE RESULT` (CMD with the two paths appended, as separate
// quoted words) in its own process group, with stdout and stderr captured to files, and
// reads RESULT (DESIGN section 4's result JSON). The program is killed (its whole process
// group) after `--opt timeout=SECONDS` (default 60). A crash, a timeout, a non-zero exit
// status, a missing or malformed result throws ExternalMethodError naming the method; the
// harness reports it as that method's failure (exit 3) and keeps the other methods' results.
//
// The explicit scene form (format "visgate-scene", version 1, readable by visgate itself):
// meshes inline, receivers as a list ("p", "n"), and every light point stated:
//   - a light with explicit_samples and jitter 1 as it is: relation (i, j) uses
//     explicit_samples[j] for every receiver i;
//   - any other light also carries "relation_points": one array per receiver i of
//     `samples` points, relation_points[i][j] = sample_position(light, j, i). visgate's
//     reader ignores the field (it derives the same points from pattern, jitter and seed).
// Coordinates are 9-digit decimals: each reads back to the same float32 with a correctly
// rounded strtof (or Python's float() then numpy.float32()).
//
// Guarantee: the answer is the program's; visgate checks only the result's shape (one
// receiver entry per receiver, one '0'/'1' per relation, fractions in [0, 1]).
#pragma once

#include <stdexcept>
#include <string>

#include "lib/solver.h"

namespace visgate::external {

// A failure of an external method (crash, timeout, exit status, malformed result);
// what() starts with the method's name.
class ExternalMethodError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The explicit scene form described above.
std::string write_explicit_scene_json(const Scene& scene);

// Parses a result JSON (DESIGN section 4) for `scene`: bits from "visible", fractions from
// "visible_fraction" when given (else from the bits), "seconds" and numeric "stats" into
// stats ("reported_seconds" and the names given). Errors name `origin` and the element.
Result<SolveResult> read_result_json(const std::string& text, const Scene& scene, const std::string& origin);

class ExecSolver final : public Solver {
 public:
  explicit ExecSolver(std::string command) : command_(std::move(command)) {}
  std::string name() const override { return "exec:" + command_; }
  std::vector<OptionSpec> options() const override;
  bool normalises_scale() const override { return false; }  // the program answers the scene as given

 protected:
  // seconds: wall time of writing the scene, running the program and reading its result.
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;

 private:
  std::string command_;
};

inline constexpr long kDefaultExecTimeoutSeconds = 60;

}  // namespace visgate::external
