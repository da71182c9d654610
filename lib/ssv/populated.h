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
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>
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

// A fixed-size array of zero bytes on a populated mapping (small blocks zeroed by
// memset): mmap'ed pages are zero already, so the elements need no per-element
// value-initialisation (a PopulatedVector's resize stores every element: 4M stores and a
// 9 MB memset for the edge tree's arrays at 300k triangles). For T whose zero bytes are
// its value-initialised state (scalars, and aggregates of them whose default member
// initialisers are all zero), the contents equal a value-initialised PopulatedVector's.
template <class T>
class PopulatedArray {
  static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);

 public:
  PopulatedArray() = default;
  explicit PopulatedArray(size_t n) : n_(n) {
    if (n == 0) return;
    if (n > size_t(-1) / sizeof(T)) throw std::bad_alloc();
    p_ = static_cast<T*>(populated_allocate(n * sizeof(T)));
    if (n * sizeof(T) < kPopulateBytes) std::memset(static_cast<void*>(p_), 0, n * sizeof(T));
  }
  PopulatedArray(PopulatedArray&& o) noexcept : p_(std::exchange(o.p_, nullptr)), n_(std::exchange(o.n_, 0)) {}
  PopulatedArray& operator=(PopulatedArray&& o) noexcept {
    if (this != &o) {
      release();
      p_ = std::exchange(o.p_, nullptr);
      n_ = std::exchange(o.n_, 0);
    }
    return *this;
  }
  PopulatedArray(const PopulatedArray&) = delete;
  PopulatedArray& operator=(const PopulatedArray&) = delete;
  ~PopulatedArray() { release(); }
  T* data() { return p_; }
  const T* data() const { return p_; }
  size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  size_t capacity() const { return n_; }
  T& operator[](size_t i) { return p_[i]; }
  const T& operator[](size_t i) const { return p_[i]; }

 private:
  void release() noexcept {
    if (p_) populated_deallocate(p_, n_ * sizeof(T));
    p_ = nullptr;
    n_ = 0;
  }
  T* p_ = nullptr;
  size_t n_ = 0;
};

}  // namespace visgate::ssv
