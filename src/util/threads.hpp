#pragma once
// The parallel loop of weft's hot parts (TBB), for work cut into pieces whose results are
// combined in a fixed order (weft/threads.hpp).
#include <cstddef>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "weft/threads.hpp"

namespace weft {

/// Runs body(k) once for every k in [0, count), on the threads allowed (set_thread_count).
/// The pieces must only read shared state, and write their own results.
template <class Body>
void parallel_chunks(size_t count, const Body& body) {
  if (count <= 1) {
    for (size_t k = 0; k < count; ++k) body(k);
    return;
  }
  tbb::parallel_for(size_t{0}, count, [&body](size_t k) { body(k); });
}

/// Sorts v by operator< on the threads allowed. For elements whose order is total (no two
/// unequal elements compare equivalent) the result is the one std::sort gives.
template <class Vector>
void parallel_sort(Vector& v) {
  tbb::parallel_sort(v.begin(), v.end());
}

}  // namespace weft
