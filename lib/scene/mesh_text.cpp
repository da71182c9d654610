// Numbers in mesh text files (see mesh_text.h).
#include "lib/scene/mesh_text.h"

#include <cctype>
#include <cmath>
#include <cstdlib>

namespace visgate {

bool decimal_syntax(const std::string& tok) {
  size_t i = 0, n = tok.size();
  if (i < n && (tok[i] == '+' || tok[i] == '-')) ++i;
  size_t digits = 0;
  while (i < n && std::isdigit(static_cast<unsigned char>(tok[i]))) ++i, ++digits;
  if (i < n && tok[i] == '.') {
    ++i;
    while (i < n && std::isdigit(static_cast<unsigned char>(tok[i]))) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < n && (tok[i] == 'e' || tok[i] == 'E')) {
    ++i;
    if (i < n && (tok[i] == '+' || tok[i] == '-')) ++i;
    size_t exp = 0;
    while (i < n && std::isdigit(static_cast<unsigned char>(tok[i]))) ++i, ++exp;
    if (exp == 0) return false;
  }
  return i == n;
}

bool finite_number(const std::string& tok, double& out) {
  if (!decimal_syntax(tok)) return false;
  out = std::strtod(tok.c_str(), nullptr);
  return std::isfinite(out);
}

// A decimal number that a float read accepts (underflow to zero or a subnormal is
// accepted by the stream; overflow is not).
bool float_number(const std::string& tok, double& out) {
  if (!finite_number(tok, out)) return false;
  const float f = std::strtof(tok.c_str(), nullptr);
  return std::isfinite(f);
}

std::string number_error(const std::string& tok, size_t line, const std::string& what) {
  const std::string at = "line " + std::to_string(line) + ": " + what + ": ";
  double v = 0;
  if (finite_number(tok, v)) return at + "'" + tok.substr(0, 32) + "' overflows float32";
  if (decimal_syntax(tok)) return at + "'" + tok.substr(0, 32) + "' overflows double";
  std::string lower;
  for (char c : tok.substr(0, 16)) lower += char(std::tolower(static_cast<unsigned char>(c)));
  const size_t sign = lower.size() > 0 && (lower[0] == '+' || lower[0] == '-') ? 1 : 0;
  if (lower.compare(sign, 3, "nan") == 0 || lower.compare(sign, 3, "inf") == 0) return at + "coordinate is NaN or infinite";
  return at + "not a decimal number: '" + tok.substr(0, 32) + "'";
}

}  // namespace visgate
