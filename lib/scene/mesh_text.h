// Numbers in mesh text files exactly as the C++ streams OpenMesh's readers use parse
// them (num_get: strtod or strtof on [+-]digits[.digits][(e|E)[+-]digits]): hex floats
// ("0x1p3" reads as 0 and leaves "x1p3"), "inf" and "nan" fail the stream, and so does a
// float that overflows float32 ("1e39"): each would leave later values uninitialised.
// Shared by the pre-scans of mesh_io.cpp and the PLY reader (ply.h).
#pragma once

#include <cstddef>
#include <string>

namespace visgate {

// `tok` has the decimal syntax above.
bool decimal_syntax(const std::string& tok);
// A decimal number whose double value (strtod) is finite.
bool finite_number(const std::string& tok, double& out);
// A decimal number that a float read accepts (underflow to zero or a subnormal is
// accepted by the stream; overflow is not).
bool float_number(const std::string& tok, double& out);
// Why `tok` is refused as a number of `what` on line `line`.
std::string number_error(const std::string& tok, size_t line, const std::string& what);

}  // namespace visgate
