#include "lib/scene/float_text.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace visgate {

std::string float_to_decimal(float f) {
  // JSON readers take "-0" for the integer 0 and drop the sign: write "-0.0".
  if (f == 0.0f && std::signbit(f)) return "-0.0";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.9g", double(f));
  return buf;
}

std::string float_to_hex(float f) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%a", double(f));
  return buf;
}

std::string double_to_decimal(double d) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.17g", d);
  return buf;
}

std::optional<float> parse_float(const std::string& s) {
  if (s.empty()) return std::nullopt;
  const char* begin = s.c_str();
  char* end = nullptr;
  errno = 0;
  float f = std::strtof(begin, &end);
  if (end == begin || *end != '\0') return std::nullopt;
  return f;  // overflow gives +-inf (ERANGE), caught by the caller's finiteness check
}

}  // namespace visgate
