// The differential check shared by fuzz_iss, fuzz_ssv, fuzz_plucker and fuzz_embree
// (DESIGN section 5): decode a small scene (fuzz/decoder.h), solve it with the method
// under the options the input selects, classify every relation with the exact relation
// oracle, and, for fragment methods, compare every receiver's visible fraction with the
// region oracle and one interior point of every fragment with the relation oracle
// (oracle/comparator.h compare_regions). A mismatch (a non-degenerate relation with
// margin >= tau the method gets wrong, a visible fraction off by more than 1e-4, or a
// fragment holding a point blocked with margin >= tau) is printed with the method,
// its options, the relation, the exact class, the margin and the scene in hex-float
// (write_scene_json with hex = true), then the process aborts so libFuzzer keeps the
// input. An exception escaping the method (a failed VG_CHECK) is reported the same way.
#pragma once

#include <cstddef>
#include <cstdint>

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

}  // namespace visgate::fuzz
