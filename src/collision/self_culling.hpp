#pragma once
// Self-collision culling by normal cones and contours (docs/collisions.md, "Self-collision
// culling"): which regions of the cloth (the subtrees of its bounding-volume tree) cannot hold
// two primitives that share no node within a distance r, so that their own pairs need not be
// looked at.
//
// A region is passed over when, at every time of the step (positions moving on straight lines
// from xa to xb):
//  1. its triangles' normals, oriented by their vertex order, lie within a cone of half-angle
//     theta < 90 degrees about an axis V (for a moving triangle, the normal is a quadratic in
//     time whose Bernstein control vectors bound it: the cone holds the three);
//  2. cos(theta) times the smallest altitude of its triangles is at least r (moving, a bound
//     on the altitude at every time: cos(theta) times the shortest control vector over the
//     longest edge at either end);
//  3. its contour (the edges of its triangles that the region does not hold on both sides,
//     with their direction) projected on the plane orthogonal to V keeps every two segments
//     that share no end at least r apart, and every segment's far end at least r from a
//     segment it shares the other end with.
// Why that suffices (Volino and Magnenat-Thalmann 1994 give 1 and the simplicity of the
// contour for intersections; 2 and the distances of 3 carry it to proximity): by 1 every
// triangle projects on the plane with the same orientation, so the number of triangles over a
// point of the plane is the winding number of the projected contour about it, which 3 keeps at
// 0 or 1: the projection is one to one. Two primitives sharing no node at a distance below r
// are, projected, below r apart too (projection shortens), and two plane segments that do not
// cross are nearest at an end of one: so some vertex v is projected within r of a primitive
// outside its star. The straight path between them either crosses the projected star's outer
// edges, which are at least cos(theta) times an altitude from v (2 forbids), or leaves the
// region through a contour segment at v and comes back through another within r of it (3
// forbids). So the region holds no such pair, and the tests left out would all have found
// nothing: with culling the pairs found are the same, in the same order.
#include <array>
#include <vector>

#include "collision/aabb_tree.hpp"
#include "weft/types.hpp"

namespace weft {

/// Counts of what the culling did (summed over its calls).
struct SelfCullingStatistics {
  long calls = 0;
  long regions_culled = 0;     ///< regions passed over
  long triangles_culled = 0;   ///< triangles in them
  long contour_checks = 0;     ///< regions whose contour was checked (1 and 2 held)
  long contour_failures = 0;   ///< of those, contours that failed 3
};

class SelfCulling {
 public:
  SelfCulling() = default;
  /// For `tree` (built over `triangles`, whose vertex order orients them): each node's contour
  /// from the topology alone. A node whose contour holds an edge twice in the same direction
  /// (triangles of opposite orientation, or more than two at an edge) is never passed over.
  SelfCulling(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree);

  /// Flags (one per node of the tree, in `skip`) the regions that hold no two primitives sharing
  /// no node within `r` (m) at any time of the step from `xa` to `xb` (3 doubles per vertex; the
  /// same vector for positions at rest in time); the top-most such regions only, their
  /// descendants 0. Runs on the threads allowed, with the same result at any thread count.
  /// `triangles` and `tree` are the ones it was made for.
  void find(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree, const VecX& xa, const VecX& xb,
            double r, std::vector<char>& skip);

  const SelfCullingStatistics& statistics() const { return stats_; }

 private:
  bool contour_clear(int node, const Vec3& axis, const VecX& xa, const VecX& xb, bool moving, double r);

  std::vector<std::array<int, 2>> contour_;  ///< directed edges, per node from contour_begin_
  std::vector<int> contour_begin_;           ///< node count + 1 offsets
  std::vector<char> never_;                  ///< per node: its contour holds an edge twice
  std::vector<int> leaves_;                  ///< the tree's leaves

  // Scratch of one call.
  struct Cone {
    Vec3 axis = Vec3::UnitZ();
    double cosine = 0, sine = 1;  ///< of its half-angle; cosine <= 0: no cone (90 degrees or more)
    double altitude = 0;          ///< the smallest altitude bound of its triangles (m)
  };
  std::vector<Cone> cone_;                    ///< per node
  struct Segment {
    std::array<double, 2> lo, hi;  ///< 2-D box, grown by r / 2
    int a, b;                      ///< its ends
  };
  std::vector<Segment> segments_;
  std::vector<int> sorted_;
  SelfCullingStatistics stats_;
};

}  // namespace weft
