#include <gtest/gtest.h>

#include <cstdint>

#include "linalg/aligned_allocator.hpp"

namespace weft {
namespace {

// The SIMD kernels load 32 bytes at offsets that are multiples of 32 from an array's start;
// they stay within one cache line only when the start is on a 64-byte boundary.
TEST(AlignedVector, DataStartsOnACacheLineWhateverTheSizeAndAfterGrowing) {
  for (size_t n : {1, 3, 12, 36, 1000, 100000, 1000003}) {
    AlignedVector<double> v(n, 1.0);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % 64, 0u) << n;
    v.resize(2 * n + 5, 2.0);  // reallocates
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % 64, 0u) << n;
    EXPECT_EQ(v[n - 1], 1.0);
    EXPECT_EQ(v[2 * n], 2.0);
  }
  AlignedVector<char> c(7);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.data()) % 64, 0u);
}

}  // namespace
}  // namespace weft
