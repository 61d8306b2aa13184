#include "collision/aabb_tree.hpp"

#include <algorithm>

namespace weft {

namespace {

Vec3 vertex(const double* xyz, int i) { return Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

}  // namespace

AabbTree::AabbTree(const std::vector<std::array<int, 3>>& triangles, const double* xyz) : triangles_(triangles) {
  if (triangles_.empty()) return;
  std::vector<Vec3> centroid(triangles_.size());
  for (size_t f = 0; f < triangles_.size(); ++f) {
    const auto& t = triangles_[f];
    centroid[f] = (vertex(xyz, t[0]) + vertex(xyz, t[1]) + vertex(xyz, t[2])) / 3;
  }
  std::vector<int> order(triangles_.size());
  for (size_t f = 0; f < order.size(); ++f) order[f] = static_cast<int>(f);
  nodes_.reserve(2 * triangles_.size() - 1);
  build(order, 0, static_cast<int>(order.size()), centroid);
  refit(xyz);
}

int AabbTree::build(std::vector<int>& order, int begin, int end, const std::vector<Vec3>& centroid) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin == 1) {
    nodes_[index].triangle = order[begin];
    return index;
  }
  Box bounds;
  for (int i = begin; i < end; ++i) bounds.add(centroid[order[i]]);
  Eigen::Index axis = 0;
  (bounds.hi - bounds.lo).maxCoeff(&axis);
  // The median by position (ties by triangle number, so the shape does not depend on the
  // sorting algorithm): both halves equal in count, whatever the positions, so the depth is
  // about log2 of the triangle count.
  const int middle = begin + (end - begin) / 2;
  std::nth_element(order.begin() + begin, order.begin() + middle, order.begin() + end, [&](int a, int b) {
    const double ca = centroid[a][axis], cb = centroid[b][axis];
    return ca < cb || (ca == cb && a < b);
  });
  build(order, begin, middle, centroid);
  const int right = build(order, middle, end, centroid);
  nodes_[index].right = right;
  return index;
}

template <class Corners>
void AabbTree::refit_leaves_and_nodes(const Corners& corners, double margin) {
  const Vec3 grow = Vec3::Constant(margin);
  // Children follow their parent in depth-first order: a backward sweep meets them first.
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& n = nodes_[i];
    if (n.triangle >= 0) {
      Box b;
      corners(triangles_[n.triangle], b);
      b.lo -= grow;
      b.hi += grow;
      n.box = b;
    } else {
      const Box& l = nodes_[i + 1].box;
      const Box& r = nodes_[n.right].box;
      n.box.lo = l.lo.cwiseMin(r.lo);
      n.box.hi = l.hi.cwiseMax(r.hi);
    }
  }
}

void AabbTree::refit(const double* xyz, double margin) {
  refit_leaves_and_nodes(
      [xyz](const std::array<int, 3>& t, Box& b) {
        for (int k = 0; k < 3; ++k) b.add(vertex(xyz, t[k]));
      },
      margin);
}

void AabbTree::refit(const double* xyz_t0, const double* xyz_t1, double margin) {
  refit_leaves_and_nodes(
      [xyz_t0, xyz_t1](const std::array<int, 3>& t, Box& b) {
        for (int k = 0; k < 3; ++k) {
          b.add(vertex(xyz_t0, t[k]));
          b.add(vertex(xyz_t1, t[k]));
        }
      },
      margin);
}

}  // namespace weft
