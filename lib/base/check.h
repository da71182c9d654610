// Invariant checks (../shared/STYLE.md "Errors"). VG_CHECK is always on and cheap;
// VG_DCHECK only in debug builds. A failed check throws visgate::InternalError, which
// the CLI turns into exit code 3; the library never prints and never exits.
#pragma once

#include <stdexcept>
#include <string>

namespace visgate {

struct InternalError : std::logic_error {
  using std::logic_error::logic_error;
};

[[noreturn]] inline void check_failed(const char* expr, const char* file, int line) {
  throw InternalError(std::string("internal check failed: ") + expr + " at " + file + ":" +
                      std::to_string(line));
}

}  // namespace visgate

#define VG_CHECK(expr) \
  do { if (!(expr)) ::visgate::check_failed(#expr, __FILE__, __LINE__); } while (0)
#ifdef NDEBUG
#define VG_DCHECK(expr) do { (void)sizeof(expr); } while (0)
#else
#define VG_DCHECK(expr) VG_CHECK(expr)
#endif
