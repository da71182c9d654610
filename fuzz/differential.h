// The differential check shared by fuzz_iss, fuzz_ssv, fuzz_plucker and fuzz_embree
// (DESIGN section 5): decode a small scene (fuzz/decoder.h), solve it with the method
// under the options the input selects, classify every relation with the exact relation
// oracle, and, for fragment methods, compare one interior point of every fragment with
// the relation oracle and the visible fractions of the receiver the input chooses
// (fraction_receivers below) with the region oracle (oracle/comparator.h
// compare_regions). A mismatch (a non-degenerate relation with
// margin >= tau the method gets wrong, a visible fraction off by more than 1e-4, or a
// fragment holding a point blocked with margin >= tau) is printed with the method,
// its options, the relation, the exact class, the margin and the scene in hex-float
// (write_scene_json with hex = true), then the process aborts so libFuzzer keeps the
// input. An exception escaping the method (a failed VG_CHECK) is reported the same way.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace visgate::fuzz {

// Relation margin below which a disagreement is not a mismatch (DESIGN section 5).
constexpr double kTau = 1e-5;
// Largest tolerated visible-fraction error for fragment methods (DESIGN section 5).
constexpr double kFractionTolerance = 1e-4;

// Runs one input through `target` ("fuzz_iss", ..., see decoder.h target_method).
// Returns 0. Returns at once, without decoding, when the target's method is not
// registered in this build (make_solver gives nullptr: the method has not landed yet);
// the first such call prints one line saying so to stderr.
int run_differential(const char* target, const uint8_t* data, size_t size);

// Fragment methods (fuzz_plucker): the receivers whose visible fractions (every light)
// are checked against the region oracle, from the option selector's unused bits
// (decoder.h selector_rest): one receiver, rest % receivers. Every relation's bit and
// every fragment's interior point are still checked for all receivers. Why one: the
// exact region check (Epeck, CGAL's Boolean operations) dominates a run; with one
// receiver chosen by the input a run takes about half the CPU time (measurements and
// the trade-off: docs/log/fuzzing.md), and the fuzzer still reaches every receiver:
// mutating the selector's high bytes changes the receiver and nothing else of the
// decoded case.
// `visgate minimize` and `visgate check` check every receiver, so a finding found
// here reproduces there.
std::vector<size_t> fraction_receivers(uint32_t selector_rest, size_t receivers);

}  // namespace visgate::fuzz
