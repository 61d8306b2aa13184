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
  order_.resize(triangles_.size());
  for (size_t f = 0; f < order_.size(); ++f) order_[f] = static_cast<int>(f);
  build(0, static_cast<int>(order_.size()), centroid);
  slot_of_.resize(order_.size());
  for (size_t k = 0; k < order_.size(); ++k) slot_of_[order_[k]] = static_cast<int>(k);
  boxes_.resize(order_.size());
  refit(xyz);
}

int AabbTree::build(int begin, int end, const std::vector<Vec3>& centroid) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  nodes_[index].begin = begin;
  nodes_[index].end = end;
  if (end - begin <= kLeafSize) return index;
  Box bounds;
  for (int i = begin; i < end; ++i) bounds.add(centroid[order_[i]]);
  Eigen::Index axis = 0;
  (bounds.hi - bounds.lo).maxCoeff(&axis);
  // The median by position (ties by triangle number, so the shape does not depend on the
  // sorting algorithm): both halves equal in count, whatever the positions, so the depth is
  // about log2 of the triangle count.
  const int middle = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end, [&](int a, int b) {
    const double ca = centroid[a][axis], cb = centroid[b][axis];
    return ca < cb || (ca == cb && a < b);
  });
  build(begin, middle, centroid);
  const int right = build(middle, end, centroid);
  nodes_[index].right = right;
  return index;
}

template <class Corners>
void AabbTree::refit_boxes(const Corners& corners, double margin) {
  const Vec3 grow = Vec3::Constant(margin);
  for (size_t k = 0; k < order_.size(); ++k) {
    Box b;
    corners(triangles_[order_[k]], b);
    b.lo -= grow;
    b.hi += grow;
    boxes_[k] = b;
  }
  // Children follow their parent in depth-first order: a backward sweep meets them first.
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& n = nodes_[i];
    Box b;
    if (n.leaf()) {
      for (int k = n.begin; k < n.end; ++k) {
        b.lo = b.lo.cwiseMin(boxes_[k].lo);
        b.hi = b.hi.cwiseMax(boxes_[k].hi);
      }
    } else {
      const Box& l = nodes_[i + 1].box;
      const Box& r = nodes_[n.right].box;
      b.lo = l.lo.cwiseMin(r.lo);
      b.hi = l.hi.cwiseMax(r.hi);
    }
    n.box = b;
  }
}

void AabbTree::self_pair_pieces(std::array<int, 2> item, int depth, std::vector<std::array<int, 2>>& pieces,
                                const char* skip) const {
  // As self_pairs_from's stack takes them: the children pushed last are finished first.
  const auto [a, b] = item;
  const Node& na = nodes_[a];
  if (a == b) {
    if (skip && skip[a]) return;
    if (depth == 0 || na.leaf()) {
      pieces.push_back(item);
      return;
    }
    self_pair_pieces({a + 1, na.right}, depth - 1, pieces, skip);
    self_pair_pieces({na.right, na.right}, depth - 1, pieces, skip);
    self_pair_pieces({a + 1, a + 1}, depth - 1, pieces, skip);
    return;
  }
  const Node& nb = nodes_[b];
  if (!na.box.overlaps(nb.box)) return;
  if (depth == 0 || (na.leaf() && nb.leaf())) {
    pieces.push_back(item);
  } else if (split_first(na, nb)) {
    self_pair_pieces({na.right, b}, depth - 1, pieces, skip);
    self_pair_pieces({a + 1, b}, depth - 1, pieces, skip);
  } else {
    self_pair_pieces({a, nb.right}, depth - 1, pieces, skip);
    self_pair_pieces({a, b + 1}, depth - 1, pieces, skip);
  }
}

void AabbTree::refit(const double* xyz, double margin) {
  refit_boxes(
      [xyz](const std::array<int, 3>& t, Box& b) {
        for (int k = 0; k < 3; ++k) b.add(vertex(xyz, t[k]));
      },
      margin);
}

void AabbTree::refit(const double* xyz_t0, const double* xyz_t1, double margin) {
  refit_boxes(
      [xyz_t0, xyz_t1](const std::array<int, 3>& t, Box& b) {
        for (int k = 0; k < 3; ++k) {
          b.add(vertex(xyz_t0, t[k]));
          b.add(vertex(xyz_t1, t[k]));
        }
      },
      margin);
}

}  // namespace weft
