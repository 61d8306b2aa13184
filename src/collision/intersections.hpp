#pragma once
// Counting intersecting triangle pairs in output frames (docs/collision-geometry.md, "Checking"):
// a cloth against itself, and a cloth against another mesh (a body).
#include <array>
#include <cstddef>
#include <vector>

#include "collision/aabb_tree.hpp"
#include "weft/frame_check.hpp"

namespace weft {

/// The pairs of triangles of one mesh that intersect (geometry.hpp: closed triangles, touching
/// counts) and share no vertex; pairs are (lower, higher) triangle numbers. `tree` must be
/// built over the same triangles and refitted to `xyz` (3 doubles per vertex, margin 0).
IntersectionCount self_intersections(const double* xyz, const AabbTree& tree, size_t examples = 8);
/// The same with a tree built here.
IntersectionCount self_intersections(const double* xyz, const std::vector<std::array<int, 3>>& triangles,
                                     size_t examples = 8);

/// The pairs (triangle of a, triangle of b) of two meshes that intersect; trees as above.
IntersectionCount mesh_intersections(const double* xyz_a, const AabbTree& tree_a, const double* xyz_b,
                                     const AabbTree& tree_b, size_t examples = 8);

}  // namespace weft
