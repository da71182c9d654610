// Binary test files: a value's bytes appended in either byte order (PLY and STL bodies).
#pragma once

#include <algorithm>
#include <cstring>
#include <string>

namespace visgate::test {

template <class T>
void put_bin(std::string& out, T v, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

}  // namespace visgate::test
