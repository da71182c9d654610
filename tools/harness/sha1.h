// SHA-1 (FIPS 180-4) of a byte string, for content-addressed corpus file names
// (DESIGN section 8). Not used for security: only as a stable content hash.
#pragma once

#include <string>

namespace visgate::harness {

// Lower-case hexadecimal digest (40 characters).
std::string sha1_hex(const std::string& data);

}  // namespace visgate::harness
