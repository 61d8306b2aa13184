#pragma once
// How far placement stretched a pattern: the largest relative change of an edge's length
// from the flat panel (the placed mesh's pattern coordinates) to its placed positions.
#include <algorithm>
#include <cmath>

#include "weft/garment/placement.hpp"

namespace weft::test {

inline double largest_edge_stretch(const PlacedGarment& placed) {
  double worst = 0;
  for (const auto& t : placed.mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      const double flat = (placed.mesh.pattern[a] - placed.mesh.pattern[b]).norm();
      const double placed_length = (placed.mesh.positions.row(a) - placed.mesh.positions.row(b)).norm();
      worst = std::max(worst, std::abs(placed_length / flat - 1));
    }
  return worst;
}

}  // namespace weft::test
