#pragma once
// ColliderContacts::query_nodes, shared by detection and the fail-safe.
#include <algorithm>

#include "collision/colliders.hpp"
#include "util/threads.hpp"

namespace weft {

template <class Query>
void ColliderContacts::query_nodes(const Query& query) {
  const int n = static_cast<int>(scene_held_.size());
  found_.assign(n, 0);
  surface_.resize(n);
  constexpr int kChunk = 256;
  parallel_chunks((n + kChunk - 1) / kChunk, [&](size_t k) {
    for (int i = static_cast<int>(k) * kChunk, end = std::min(n, i + kChunk); i < end; ++i)
      if (!scene_held_[i]) found_[i] = query(i, surface_[i]) ? 1 : 0;
  });
}

}  // namespace weft
