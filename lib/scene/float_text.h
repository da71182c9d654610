// Bit-exact float text (DESIGN section 2): decimal with 9 significant digits or C99
// hex-float, both read back to the identical float32.
#pragma once

#include <optional>
#include <string>

namespace visgate {

// "%.9g": the shortest fixed-width decimal that round-trips every float32.
std::string float_to_decimal(float f);
// C99 hex-float, e.g. "0x1.8p+1".
std::string float_to_hex(float f);
// Parses a decimal or hex-float string in full (strtof: correctly rounded). Returns
// nullopt when the text is not a number or has trailing characters. NaN and infinities
// are returned as such; callers reject them with the element's name.
std::optional<float> parse_float(const std::string& s);
// Shortest-ish double text that round-trips (17 significant digits).
std::string double_to_decimal(double d);

}  // namespace visgate
