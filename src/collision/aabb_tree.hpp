#pragma once
// A bounding-volume hierarchy of axis-aligned boxes over the triangles of a mesh: its shape is
// built once from the topology and a set of positions; each step only refits the boxes to
// the new positions (docs/collision-geometry.md, "Detection").
#include <array>
#include <limits>
#include <vector>

#include "util/threads.hpp"
#include "weft/types.hpp"

namespace weft {

/// A closed axis-aligned box.
struct Box {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool overlaps(const Box& o) const {
    return lo.x() <= o.hi.x() && o.lo.x() <= hi.x() && lo.y() <= o.hi.y() && o.lo.y() <= hi.y() &&
           lo.z() <= o.hi.z() && o.lo.z() <= hi.z();
  }
};

class AabbTree {
 public:
  AabbTree() = default;
  /// A tree over `triangles` (#F vertex triples), split at the median of the triangles'
  /// centroids along the longest side of their bounds down to leaves of at most 4 triangles,
  /// with the positions `xyz` (3 doubles per vertex); its boxes are fitted to them.
  AabbTree(const std::vector<std::array<int, 3>>& triangles, const double* xyz);

  /// Refits every box to the positions `xyz` (same vertex numbering), grown by `margin` (m) on
  /// every side.
  void refit(const double* xyz, double margin = 0);
  /// Refits every box to the swept volume of a step: each triangle's box holds its vertices at
  /// both `xyz_t0` and `xyz_t1`, grown by `margin`; so it holds the triangle at every time of
  /// the step (straight trajectories).
  void refit(const double* xyz_t0, const double* xyz_t1, double margin);

  int triangle_count() const { return static_cast<int>(triangles_.size()); }
  const std::vector<std::array<int, 3>>& triangles() const { return triangles_; }
  /// The box of everything (empty box for an empty tree).
  Box bounds() const { return nodes_.empty() ? Box{} : nodes_[0].box; }
  /// The box of triangle f as last refitted.
  const Box& triangle_box(int f) const { return boxes_[slot_of_[f]]; }

  /// The tree's nodes, in depth-first order (0 is the root): a node's first child follows it,
  /// its second is node_right(i); a node holds the triangles of slots [node_begin, node_end)
  /// of slot_triangles(), its descendants' together.
  int node_count() const { return static_cast<int>(nodes_.size()); }
  /// The most triangles a leaf holds.
  static constexpr int kMaxLeafTriangles = 4;
  bool node_leaf(int i) const { return nodes_[i].leaf(); }
  int node_right(int i) const { return nodes_[i].right; }
  int node_begin(int i) const { return nodes_[i].begin; }
  int node_end(int i) const { return nodes_[i].end; }
  const std::vector<int>& slot_triangles() const { return order_; }

  /// Calls f(triangle) for every triangle whose box overlaps `box`.
  template <class F>
  void for_each_overlapping(const Box& box, F&& f) const;
  /// The triangle nearest p within `reach`, by `distance(triangle)` (its distance from p, no
  /// less than the distance from p to its box), or -1 if none is within it. Of triangles at
  /// the same distance, the first in the tree's order (the order for_each_overlapping visits
  /// them in), so the answer depends on neither the search's order nor on `reach` beyond the
  /// nearest distance. `nearest` is set to that distance. Boxes farther than the nearest
  /// triangle found so far are not opened, the nearer child first.
  template <class Distance>
  int nearest(const Vec3& p, double reach, Distance&& distance, double& nearest) const;
  /// Calls f(i, j) once for every unordered pair of distinct triangles (in either order) whose
  /// boxes overlap. Neighbours in the mesh are included: callers filter them.
  template <class F>
  void for_each_self_pair(F&& f) const;
  /// The pairs (i, j) for_each_self_pair gives, in its order, for which keep(i, j) holds, found
  /// on every thread allowed: the traversal is cut into the pairs of subtrees it takes in turn
  /// (the same cut at any thread count), each piece's pairs collected apart and the pieces
  /// joined in the traversal's order, so `out` holds the same pairs in the same order whatever
  /// the number of threads. keep is called from several threads at once. `pieces` is scratch
  /// kept between calls. `skip_within` (one flag per node, or null): the pairs of triangles
  /// both in a flagged node's subtree are left out (SelfCulling), the others keep their order.
  template <class Keep>
  void collect_self_pairs(const Keep& keep, std::vector<std::array<int, 2>>& out,
                          std::vector<std::vector<std::array<int, 2>>>& pieces,
                          const std::vector<char>* skip_within = nullptr) const;
  /// Calls f(mine, theirs) for every pair of a triangle of this tree and one of `other` whose
  /// boxes overlap.
  template <class F>
  void for_each_pair(const AabbTree& other, F&& f) const;

 private:
  static constexpr int kLeafSize = kMaxLeafTriangles;
  struct Node {
    Box box;
    int right = -1;  ///< the second child; the first is the next node (depth-first order); -1 for a leaf
    int begin = 0, end = 0;  ///< a leaf's slots in order_ and boxes_
    bool leaf() const { return right < 0; }
  };
  // Descending a pair of nodes, the larger one (by the sum of its box's sides) is split,
  // so the boxes compared stay of similar size.
  static bool split_first(const Node& a, const Node& b) {
    return b.leaf() || (!a.leaf() && (a.box.hi - a.box.lo).sum() >= (b.box.hi - b.box.lo).sum());
  }
  int build(int begin, int end, const std::vector<Vec3>& centroid);
  // for_each_self_pair's traversal from one pair of nodes (a == b: the pairs within a subtree).
  // `skip` (or null): nodes whose own pairs are left out.
  template <class F>
  void self_pairs_from(std::array<int, 2> start, F&& f, const char* skip = nullptr) const;
  // Appends the pairs of nodes that the traversal from `item` reaches `depth` levels down, in
  // the order it finishes them (items that give nothing are left out).
  void self_pair_pieces(std::array<int, 2> item, int depth, std::vector<std::array<int, 2>>& pieces,
                        const char* skip = nullptr) const;
  template <class Corners>
  void refit_boxes(const Corners& corners, double margin);

  std::vector<std::array<int, 3>> triangles_;
  std::vector<Node> nodes_;
  std::vector<int> order_;    ///< triangle numbers, each leaf's contiguous
  std::vector<int> slot_of_;  ///< inverse of order_
  std::vector<Box> boxes_;    ///< per slot: the box of triangle order_[slot]
};

template <class F>
void AabbTree::for_each_overlapping(const Box& box, F&& f) const {
  if (nodes_.empty()) return;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int i = stack[--top];
    const Node& n = nodes_[i];
    if (!n.box.overlaps(box)) continue;
    if (n.leaf()) {
      for (int k = n.begin; k < n.end; ++k)
        if (boxes_[k].overlaps(box)) f(order_[k]);
      continue;
    }
    stack[top++] = n.right;
    stack[top++] = i + 1;
  }
}

namespace detail {
// The squared distance from p to the box (0 inside it).
inline double box_distance2(const Box& b, const Vec3& p) {
  return (b.lo - p).cwiseMax(p - b.hi).cwiseMax(0.0).squaredNorm();
}
}  // namespace detail

template <class Distance>
int AabbTree::nearest(const Vec3& p, double reach, Distance&& distance, double& nearest) const {
  nearest = reach;
  if (nodes_.empty()) return -1;
  int best_slot = -1;
  double best2 = reach * reach;
  struct Entry {
    int node;
    double distance2;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {0, detail::box_distance2(nodes_[0].box, p)};
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.distance2 > best2) continue;
    const Node& n = nodes_[e.node];
    if (n.leaf()) {
      for (int k = n.begin; k < n.end; ++k) {
        if (detail::box_distance2(boxes_[k], p) > best2) continue;
        const double d = distance(order_[k]);
        if (d < nearest || (d == nearest && (best_slot < 0 || k < best_slot))) {
          nearest = d;
          best2 = d * d;
          best_slot = k;
        }
      }
      continue;
    }
    const Entry left{e.node + 1, detail::box_distance2(nodes_[e.node + 1].box, p)};
    const Entry right{n.right, detail::box_distance2(nodes_[n.right].box, p)};
    // The nearer child on top, opened first.
    if (left.distance2 <= right.distance2) {
      if (right.distance2 <= best2) stack[top++] = right;
      if (left.distance2 <= best2) stack[top++] = left;
    } else {
      if (left.distance2 <= best2) stack[top++] = left;
      if (right.distance2 <= best2) stack[top++] = right;
    }
  }
  return best_slot < 0 ? -1 : order_[best_slot];  // nearest stays at reach when none is found
}

template <class F>
void AabbTree::for_each_self_pair(F&& f) const {
  if (nodes_.empty()) return;
  self_pairs_from({0, 0}, f);
}

template <class Keep>
void AabbTree::collect_self_pairs(const Keep& keep, std::vector<std::array<int, 2>>& out,
                                  std::vector<std::vector<std::array<int, 2>>>& pieces,
                                  const std::vector<char>* skip_within) const {
  out.clear();
  if (nodes_.empty()) return;
  const char* skip =
      skip_within && skip_within->size() == nodes_.size() ? skip_within->data() : nullptr;
  // Subtree pairs six levels down (a few hundred on a cloth of thousands of triangles), taken
  // 8 to a piece of work.
  constexpr int kDepth = 6;
  constexpr size_t kPerPiece = 8;
  std::vector<std::array<int, 2>> starts;
  self_pair_pieces({0, 0}, kDepth, starts, skip);
  const size_t count = (starts.size() + kPerPiece - 1) / kPerPiece;
  if (pieces.size() < count) pieces.resize(count);
  parallel_chunks(count, [&](size_t k) {
    std::vector<std::array<int, 2>>& found = pieces[k];
    found.clear();
    for (size_t s = k * kPerPiece, end = std::min(starts.size(), s + kPerPiece); s < end; ++s)
      self_pairs_from(
          starts[s],
          [&](int i, int j) {
            if (keep(i, j)) found.push_back({i, j});
          },
          skip);
  });
  for (size_t k = 0; k < count; ++k) out.insert(out.end(), pieces[k].begin(), pieces[k].end());
}

template <class F>
void AabbTree::self_pairs_from(std::array<int, 2> start, F&& f, const char* skip) const {
  // Pairs (a, b) of nodes to visit; a == b stands for the pairs within one subtree.
  std::vector<std::array<int, 2>> stack;
  stack.reserve(256);
  stack.push_back(start);
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node& na = nodes_[a];
    if (a == b) {
      if (skip && skip[a]) continue;
      if (na.leaf()) {
        for (int i = na.begin; i < na.end; ++i)
          for (int j = i + 1; j < na.end; ++j)
            if (boxes_[i].overlaps(boxes_[j])) f(order_[i], order_[j]);
        continue;
      }
      stack.push_back({a + 1, a + 1});
      stack.push_back({na.right, na.right});
      stack.push_back({a + 1, na.right});
      continue;
    }
    const Node& nb = nodes_[b];
    if (!na.box.overlaps(nb.box)) continue;
    if (na.leaf() && nb.leaf()) {
      for (int i = na.begin; i < na.end; ++i) {
        if (!boxes_[i].overlaps(nb.box)) continue;
        for (int j = nb.begin; j < nb.end; ++j)
          if (boxes_[i].overlaps(boxes_[j])) f(order_[i], order_[j]);
      }
    } else if (split_first(na, nb)) {
      stack.push_back({a + 1, b});
      stack.push_back({na.right, b});
    } else {
      stack.push_back({a, b + 1});
      stack.push_back({a, nb.right});
    }
  }
}

template <class F>
void AabbTree::for_each_pair(const AabbTree& other, F&& f) const {
  if (nodes_.empty() || other.nodes_.empty()) return;
  std::vector<std::array<int, 2>> stack;
  stack.reserve(256);
  stack.push_back({0, 0});
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node& na = nodes_[a];
    const Node& nb = other.nodes_[b];
    if (!na.box.overlaps(nb.box)) continue;
    if (na.leaf() && nb.leaf()) {
      for (int i = na.begin; i < na.end; ++i) {
        if (!boxes_[i].overlaps(nb.box)) continue;
        for (int j = nb.begin; j < nb.end; ++j)
          if (boxes_[i].overlaps(other.boxes_[j])) f(order_[i], other.order_[j]);
      }
    } else if (split_first(na, nb)) {
      stack.push_back({a + 1, b});
      stack.push_back({na.right, b});
    } else {
      stack.push_back({a, b + 1});
      stack.push_back({a, nb.right});
    }
  }
}

}  // namespace weft
