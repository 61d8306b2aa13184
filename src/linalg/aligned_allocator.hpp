#pragma once
// std::vector storage aligned to cache lines (64 bytes), so that four-wide vector loads from
// 32-byte-aligned offsets never straddle two lines. (The default allocator aligns to 16
// bytes: half the 32-byte loads of an array walked in 32-byte steps would then cross a line,
// which costs a second access to the cache.)
#include <cstddef>
#include <new>
#include <vector>

namespace weft {

template <class T>
struct CacheLineAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{64};
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kAlignment)); }
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, kAlignment); }
  template <class U>
  bool operator==(const CacheLineAllocator<U>&) const noexcept {
    return true;
  }
};

/// A std::vector whose data starts on a cache line.
template <class T>
using AlignedVector = std::vector<T, CacheLineAllocator<T>>;

}  // namespace weft
