// SHA-256 (FIPS 180-4) of a byte string, for the input and output hashes of the repair
// report (DESIGN section 7: `visgate repair --report`). Small and self-contained so the
// project needs no crypto library; tested against the FIPS 180-4 example vectors.
#pragma once

#include <string>
#include <string_view>

namespace visgate::mesh {

// Lower-case hexadecimal digest (64 characters).
std::string sha256_hex(std::string_view bytes);

}  // namespace visgate::mesh
