// An allocator whose large blocks come from the OS with their pages mapped in one call.
//
// Why: on the bench's VM a first touch of a fresh 4 KiB page traps to the hypervisor
// (about 20-25 us a page: 14 MB zero-filled by first touches took 88 ms, the same 14 MB
// mapped with MAP_POPULATE 7 ms, idle). SSV builds its edge hierarchy once per solve over
// every edge (about 17 MB at 300k triangles), and those first touches were most of its
// build (measured in `visgate bench targets`, docs/log/ssv-performance.md, sixth round).
// Blocks of at least kPopulateBytes are mmap'ed with MAP_POPULATE and unmapped on
// release; smaller ones, and every block where MAP_POPULATE does not exist, use operator
// new. The container value-initialises as usual: nothing observable changes but time.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace visgate::ssv {

inline constexpr size_t kPopulateBytes = size_t(1) << 18;

#if defined(__linux__) && defined(MAP_POPULATE)
inline void* populated_allocate(size_t bytes) {
  if (bytes < kPopulateBytes) return ::operator new(bytes);
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_POPULATE, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
  return p;
}
inline void populated_deallocate(void* p, size_t bytes) noexcept {
  if (bytes < kPopulateBytes)
    ::operator delete(p);
  else
    munmap(p, bytes);
}
#else
inline void* populated_allocate(size_t bytes) { return ::operator new(bytes); }
inline void populated_deallocate(void* p, size_t) noexcept { ::operator delete(p); }
#endif

template <class T>
struct PopulatedAllocator {
  using value_type = T;
  // mmap and operator new both align to at least max_align_t.
  static_assert(alignof(T) <= alignof(std::max_align_t));
  PopulatedAllocator() = default;
  template <class U>
  PopulatedAllocator(const PopulatedAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    if (n > size_t(-1) / sizeof(T)) throw std::bad_alloc();
    return static_cast<T*>(populated_allocate(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) noexcept { populated_deallocate(p, n * sizeof(T)); }
  template <class U>
  bool operator==(const PopulatedAllocator<U>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const PopulatedAllocator<U>&) const noexcept {
    return false;
  }
};

template <class T>
using PopulatedVector = std::vector<T, PopulatedAllocator<T>>;

}  // namespace visgate::ssv
