#pragma once
// The intersections of one output frame (docs/collisions.md, "Checking"): the cloth against
// itself and against each body, as `weft check` and `weft run` count them. The trees are kept
// between frames and only refitted while the triangles stay the same.
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

namespace weft {

/// Intersecting triangle pairs: how many, and the first few.
struct IntersectionCount {
  size_t count = 0;                          ///< intersecting pairs
  std::vector<std::array<int, 2>> examples;  ///< the first pairs found (up to the limit asked)
};

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
  explicit FrameChecker(size_t examples = 8);
  ~FrameChecker();
  FrameChecker(FrameChecker&&) noexcept;
  FrameChecker& operator=(FrameChecker&&) noexcept;
  FrameIntersections check(const FrameMesh& cloth, const std::vector<FrameMesh>& bodies);

 private:
  struct Trees;  ///< the bounding-volume trees, slot 0 the cloth, then the bodies
  size_t examples_;
  std::unique_ptr<Trees> trees_;
};

}  // namespace weft
