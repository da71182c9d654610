// The GMP limb pool of the differential fuzz targets; see gmp_pool.h.
#include "fuzz/gmp_pool.h"

#include <gmp.h>
#include <sys/mman.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <mutex>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VISGATE_GMP_POOL_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define VISGATE_GMP_POOL_ASAN 1
#endif
#ifdef VISGATE_GMP_POOL_ASAN
#include <sanitizer/asan_interface.h>
#endif

namespace visgate::fuzz {

namespace {

constexpr size_t kGrain = 16;                   // block sizes are multiples of this
constexpr size_t kClasses = 32;                 // up to 512 bytes
constexpr size_t kLargest = kGrain * kClasses;  // larger requests go to malloc
constexpr size_t kReserve = size_t(1) << 30;    // address range of the pool (reserved, not committed)

char* g_begin = nullptr;  // the reserved range [g_begin, g_end)
char* g_end = nullptr;
std::atomic<char*> g_next{nullptr};  // first never-used byte of the range

struct FreeBlock {
  FreeBlock* next;
};
thread_local FreeBlock* t_free[kClasses] = {};

bool in_pool(const void* p) {
  const char* c = static_cast<const char*>(p);
  return c >= g_begin && c < g_end;
}

size_t class_of(size_t size) { return size == 0 ? 0 : (size - 1) / kGrain; }  // block (class + 1) * kGrain

// ASan: a block in a free list is poisoned, an allocated one unpoisoned up to the size
// asked for, so instrumented code touching freed limbs (or limbs past the request) is
// still reported. GMP's own accesses are not instrumented either way.
void unpoison(void* p, size_t size) {
#ifdef VISGATE_GMP_POOL_ASAN
  ASAN_UNPOISON_MEMORY_REGION(p, size);
  const size_t block = (class_of(size) + 1) * kGrain;
  if (block > size) ASAN_POISON_MEMORY_REGION(static_cast<char*>(p) + size, block - size);
#else
  (void)p, (void)size;
#endif
}
void poison(void* p, size_t cls) {
#ifdef VISGATE_GMP_POOL_ASAN
  ASAN_POISON_MEMORY_REGION(p, (cls + 1) * kGrain);
#else
  (void)p, (void)cls;
#endif
}

void* pool_alloc(size_t size) {
  if (size == 0) size = 1;
  if (size > kLargest) return std::malloc(size);
  const size_t cls = class_of(size);
  FreeBlock* b = t_free[cls];
  if (b) {
#ifdef VISGATE_GMP_POOL_ASAN
    ASAN_UNPOISON_MEMORY_REGION(b, sizeof(FreeBlock));
#endif
    t_free[cls] = b->next;
    unpoison(b, size);
    return b;
  }
  const size_t block = (cls + 1) * kGrain;
  char* p = g_next.fetch_add(block, std::memory_order_relaxed);
  if (p + block > g_end) return std::malloc(size);  // range used up: malloc from here on
  unpoison(p, size);
  return p;
}

void pool_free(void* p, size_t size) {
  if (!p) return;
  if (!in_pool(p)) {
    std::free(p);
    return;
  }
  const size_t cls = class_of(size);
  FreeBlock* b = static_cast<FreeBlock*>(p);
#ifdef VISGATE_GMP_POOL_ASAN
  ASAN_UNPOISON_MEMORY_REGION(b, sizeof(FreeBlock));
#endif
  b->next = t_free[cls];
  t_free[cls] = b;
  poison(b, cls);  // the link too: pool_alloc unpoisons it before reading it
}

void* pool_realloc(void* p, size_t old_size, size_t new_size) {
  if (new_size == 0) new_size = 1;
  if (!p) return pool_alloc(new_size);
  if (!in_pool(p)) return std::realloc(p, new_size);
  if (new_size <= kLargest && class_of(new_size) == class_of(old_size)) {
    unpoison(p, new_size);
    return p;
  }
  void* q = pool_alloc(new_size);
  if (!q) return nullptr;
  std::memcpy(q, p, old_size < new_size ? old_size : new_size);
  pool_free(p, old_size);
  return q;
}

bool install() {
  if (const char* e = std::getenv("VISGATE_FUZZ_GMP_POOL"); e && std::strcmp(e, "0") == 0) return false;
  void* m = mmap(nullptr, kReserve, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (m == MAP_FAILED) return false;
  g_begin = static_cast<char*>(m);
  g_end = g_begin + kReserve;
  g_next.store(g_begin, std::memory_order_relaxed);
  mp_set_memory_functions(pool_alloc, pool_realloc, pool_free);
  return true;
}

}  // namespace

bool install_gmp_pool() {
  static std::once_flag once;
  static bool on = false;
  std::call_once(once, [] { on = install(); });
  return on;
}

}  // namespace visgate::fuzz
