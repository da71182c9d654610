// Floating-point error bounds in the notation of Higham and pbrt (section 6.8): u is
// the unit roundoff, gamma(n) = n u / (1 - n u) bounds the relative error of n
// successive roundings, |(1 + d_1)...(1 + d_n) - 1| <= gamma(n) when n u < 1.
#pragma once

namespace visgate {

constexpr float kUnitRoundoffF = 0x1p-24f;   // float32, round to nearest
constexpr double kUnitRoundoffD = 0x1p-53;   // double, round to nearest

constexpr double gamma_d(int n) { return (double(n) * kUnitRoundoffD) / (1.0 - double(n) * kUnitRoundoffD); }

}  // namespace visgate
