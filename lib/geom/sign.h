// The one sign type of the geometry code. Float predicates with an error bound answer
// Uncertain when the value lies within the bound of zero; filtered predicates then fall
// back to exact arithmetic; exact predicates never answer Uncertain.
//
// Naming (geogram-style): `orient3d` is the plain float value, `orient3d_filtered` the
// error-bounded sign (may be Uncertain), `orient3d_exact` the exact sign; likewise for
// every predicate.
#pragma once

#include <cstdint>

namespace visgate {

enum class Sign : int8_t { Negative = -1, Zero = 0, Positive = 1, Uncertain = 2 };

constexpr Sign sign_of(double v) { return v > 0 ? Sign::Positive : (v < 0 ? Sign::Negative : Sign::Zero); }
constexpr Sign sign_of_int(int v) { return v > 0 ? Sign::Positive : (v < 0 ? Sign::Negative : Sign::Zero); }
// The sign of v when |v| > bound (the value's error bound), else Uncertain.
constexpr Sign sign_with_bound(double v, double bound) {
  return v > bound ? Sign::Positive : (v < -bound ? Sign::Negative : Sign::Uncertain);
}
constexpr bool is_certain(Sign s) { return s != Sign::Uncertain; }
constexpr int to_int(Sign s) { return s == Sign::Uncertain ? 0 : int(s); }

}  // namespace visgate
