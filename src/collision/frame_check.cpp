#include "weft/frame_check.hpp"

#include "collision/intersections.hpp"

#include <algorithm>
#include <cstdint>

namespace weft {

size_t FrameIntersections::count() const {
  size_t n = cloth_self.count;
  for (const auto& b : cloth_body) n += b.count;
  return n;
}

struct FrameChecker::Trees {
  std::vector<AabbTree> slots;
  /// A tree for `mesh` in `slot`, refitted; rebuilt when its triangles differ from the last ones.
  const AabbTree& tree_for(size_t slot, const FrameMesh& mesh);
};

FrameChecker::FrameChecker(size_t examples) : examples_(examples), trees_(std::make_unique<Trees>()) {}
FrameChecker::~FrameChecker() = default;
FrameChecker::FrameChecker(FrameChecker&&) noexcept = default;
FrameChecker& FrameChecker::operator=(FrameChecker&&) noexcept = default;

const AabbTree& FrameChecker::Trees::tree_for(size_t slot, const FrameMesh& mesh) {
  AabbTree& tree = slots[slot];
  if (tree.triangles() != *mesh.triangles)
    tree = AabbTree(*mesh.triangles, mesh.xyz);
  else
    tree.refit(mesh.xyz);
  return tree;
}

FrameIntersections FrameChecker::check(const FrameMesh& cloth, const std::vector<FrameMesh>& bodies) {
  FrameIntersections out;
  // All slots first: the references below must outlive any growth of trees_.
  if (trees_->slots.size() < bodies.size() + 1) trees_->slots.resize(bodies.size() + 1);
  const AabbTree& cloth_tree = trees_->tree_for(0, cloth);
  out.cloth_self = self_intersections(cloth.xyz, cloth_tree, examples_);
  for (size_t k = 0; k < bodies.size(); ++k) {
    const FrameMesh& body = bodies[k];
    const AabbTree& body_tree = trees_->tree_for(k + 1, body);
    const auto& body_tris = *body.triangles;
    const IntersectionCount all = mesh_intersections(cloth.xyz, cloth_tree, body.xyz, body_tree, SIZE_MAX);
    // The body's own crossings and the triangles around them (sharing a vertex): looked for
    // only when the cloth meets the body at all, as it should not.
    std::vector<char> crossing_vertex;
    if (all.count > 0) {
      const IntersectionCount body_self = self_intersections(body.xyz, body_tree, SIZE_MAX);
      int n_vertices = 0;
      for (const auto& t : body_tris) n_vertices = std::max({n_vertices, t[0] + 1, t[1] + 1, t[2] + 1});
      crossing_vertex.assign(static_cast<size_t>(n_vertices), 0);
      for (const auto& [i, j] : body_self.examples)
        for (int f : {i, j})
          for (int a : body_tris[f]) crossing_vertex[a] = 1;
    }
    auto at_crossing = [&](int body_triangle) {
      if (crossing_vertex.empty()) return false;
      const auto& t = body_tris[body_triangle];
      return crossing_vertex[t[0]] || crossing_vertex[t[1]] || crossing_vertex[t[2]];
    };
    IntersectionCount kept;
    size_t at_crossings = 0;
    for (const auto& [c, b] : all.examples) {
      if (at_crossing(b)) {
        ++at_crossings;
        continue;
      }
      ++kept.count;
      if (kept.examples.size() < examples_) kept.examples.push_back({c, b});
    }
    out.cloth_body.push_back(std::move(kept));
    out.cloth_body_at_body_crossings.push_back(at_crossings);
  }
  return out;
}

}  // namespace weft
