#pragma once
// The intersections of one output frame (docs/collisions.md, "Checking"): the cloth against
// itself and against each body, as `weft check` and `weft run` count them. The trees are kept
// between frames and only refitted while the triangles stay the same.
#include <array>
#include <cstddef>
#include <vector>

#include "collision/intersections.hpp"

namespace weft {

/// A mesh of one frame: 3 doubles per vertex and the vertex triples of its triangles.
struct FrameMesh {
  const double* xyz = nullptr;
  const std::vector<std::array<int, 3>>* triangles = nullptr;
};

struct FrameIntersections {
  /// Pairs of cloth triangles that intersect and share no vertex.
  IntersectionCount cloth_self;
  /// Per body: (cloth triangle, body triangle) pairs that intersect, leaving out those at the
  /// body's own crossings (below).
  std::vector<IntersectionCount> cloth_body;
  /// Per body: cloth-body pairs whose body triangle crosses another triangle of the body or
  /// shares a vertex with one that does. A skinned body can cross itself (under the arms,
  /// between the thighs), and there no cloth can lie free of it; these are counted apart.
  std::vector<size_t> cloth_body_at_body_crossings;
  /// cloth_self plus every cloth_body count: what must be zero.
  size_t count() const;
};

class FrameChecker {
 public:
  /// `examples`: how many pairs of each kind to keep in the counts.
  explicit FrameChecker(size_t examples = 8) : examples_(examples) {}
  FrameIntersections check(const FrameMesh& cloth, const std::vector<FrameMesh>& bodies);

 private:
  /// A tree for `mesh`, refitted; rebuilt when its triangles differ from the last ones.
  const AabbTree& tree_for(size_t slot, const FrameMesh& mesh);

  size_t examples_;
  std::vector<AabbTree> trees_;  ///< slot 0 the cloth, then the bodies
};

}  // namespace weft
