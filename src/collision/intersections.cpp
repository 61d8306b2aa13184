#include "collision/intersections.hpp"

#include <algorithm>

#include "collision/geometry.hpp"

namespace weft {

namespace {

Vec3 vertex(const double* xyz, int i) { return Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

bool share_vertex(const std::array<int, 3>& s, const std::array<int, 3>& t) {
  for (int i : s)
    if (i == t[0] || i == t[1] || i == t[2]) return true;
  return false;
}

bool intersect(const double* xyz_s, const std::array<int, 3>& s, const double* xyz_t, const std::array<int, 3>& t) {
  return triangles_intersect(vertex(xyz_s, s[0]), vertex(xyz_s, s[1]), vertex(xyz_s, s[2]), vertex(xyz_t, t[0]),
                             vertex(xyz_t, t[1]), vertex(xyz_t, t[2]));
}

void record(IntersectionCount& out, int i, int j, size_t examples) {
  ++out.count;
  if (out.examples.size() < examples) out.examples.push_back({i, j});
}

}  // namespace

IntersectionCount self_intersections(const double* xyz, const AabbTree& tree, size_t examples) {
  IntersectionCount out;
  const auto& tris = tree.triangles();
  // The intersecting pairs, tested on every thread.
  std::vector<std::array<int, 2>> pairs;
  std::vector<std::vector<std::array<int, 2>>> pieces;
  tree.collect_self_pairs(
      [&](int i, int j) { return !share_vertex(tris[i], tris[j]) && intersect(xyz, tris[i], xyz, tris[j]); }, pairs,
      pieces);
  for (const auto& [i, j] : pairs) record(out, std::min(i, j), std::max(i, j), examples);
  // The traversal's order is fixed by the tree, but the pairs are easier to read sorted.
  std::sort(out.examples.begin(), out.examples.end());
  return out;
}

IntersectionCount self_intersections(const double* xyz, const std::vector<std::array<int, 3>>& triangles,
                                     size_t examples) {
  return self_intersections(xyz, AabbTree(triangles, xyz), examples);
}

IntersectionCount mesh_intersections(const double* xyz_a, const AabbTree& tree_a, const double* xyz_b,
                                     const AabbTree& tree_b, size_t examples) {
  IntersectionCount out;
  const auto& ta = tree_a.triangles();
  const auto& tb = tree_b.triangles();
  tree_a.for_each_pair(tree_b, [&](int i, int j) {
    if (intersect(xyz_a, ta[i], xyz_b, tb[j])) record(out, i, j, examples);
  });
  std::sort(out.examples.begin(), out.examples.end());
  return out;
}

}  // namespace weft
