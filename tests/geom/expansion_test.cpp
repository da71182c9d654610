// Tests of lib/geom/expansion.h: Shewchuk's expansion arithmetic against exact references.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lib/geom/expansion.h"
#include "lib/scene/rng.h"

using namespace visgate;

namespace {

// The value of the lowest set bit of a nonzero finite double.
double lowest_bit(double x) {
  int exp = 0;
  const double m = std::frexp(std::abs(x), &exp);  // m in [0.5, 1)
  auto mant = static_cast<uint64_t>(std::ldexp(m, 53));
  int tz = 0;
  while ((mant & 1u) == 0) {
    mant >>= 1;
    ++tz;
  }
  return std::ldexp(1.0, exp - 53 + tz);
}

// Nonoverlapping, increasing magnitude, no zeros: each component below the lowest set
// bit of the next.
template <class V>
bool well_formed(const V& e) {
  for (size_t i = 0; i < e.size(); ++i) {
    if (e[i] == 0.0 || !std::isfinite(e[i])) return false;
    if (i + 1 < e.size() && !(std::abs(e[i]) < lowest_bit(e[i + 1]))) return false;
  }
  return true;
}

// An expansion of n random doubles over a wide exponent range, with cancellation.
expansion::Small random_expansion(Rng& rng, int n) {
  expansion::Small e;
  for (int i = 0; i < n; ++i) {
    const double x = std::ldexp(rng.uniform(-1, 1), int(rng.below(120)) - 60);
    expansion::grow_vector(e, x);
    if (rng.below(4) == 0) expansion::grow_vector(e, -x * 0.5);  // partial cancellation
  }
  return e;
}

}  // namespace

TEST(Expansion, LinearScaleAndSumAreExactAgainstGrowExpansion) {
  // scale_expansion and sum_expansions (Shewchuk's Scale-Expansion and
  // Fast-Expansion-Sum) against the independent Grow-Expansion: (e + f) - h and e b - h,
  // grown term by term (each product as its exact Two-Product pair), must be exactly
  // zero, and h well formed.
  Rng rng(2026);
  int nonzero = 0, zero = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const expansion::Small e = random_expansion(rng, 1 + int(rng.below(12)));
    expansion::Small f = random_expansion(rng, int(rng.below(12)));
    if (trial % 5 == 0) {  // f = -e: the sum is exactly zero (an empty expansion)
      f = e;
      for (double& x : f) x = -x;
    }
    expansion::Small h(e.size() + f.size());
    h.resize(size_t(expansion::sum_expansions(e.data(), int(e.size()), f.data(), int(f.size()), h.data())));
    ASSERT_TRUE(well_formed(h)) << trial;
    expansion::Small check;
    for (double x : e) expansion::grow_vector(check, x);
    for (double x : f) expansion::grow_vector(check, x);
    for (double x : h) expansion::grow_vector(check, -x);
    EXPECT_TRUE(check.empty()) << trial;
    (h.empty() ? zero : nonzero) += 1;

    const double b = trial % 7 == 0 ? 0.0 : std::ldexp(rng.uniform(-1, 1), int(rng.below(80)) - 40);
    h.resize(2 * e.size());
    h.resize(size_t(expansion::scale_expansion(e.data(), int(e.size()), b, h.data())));
    ASSERT_TRUE(well_formed(h)) << trial;
    check.clear();
    for (double x : e) {
      double hi, lo;
      expansion::two_product(x, b, hi, lo);
      expansion::grow_vector(check, hi);
      expansion::grow_vector(check, lo);
    }
    for (double x : h) expansion::grow_vector(check, -x);
    EXPECT_TRUE(check.empty()) << trial;
    EXPECT_EQ(h.empty(), b == 0.0) << trial;
  }
  EXPECT_GT(zero, 300);
  EXPECT_GT(nonzero, 1000);
}
