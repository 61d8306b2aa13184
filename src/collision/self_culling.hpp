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
//
// Regions found are kept for the calls after (a sheet's shape changes little from one step to
// the next): regions holding no pair within R at positions P hold none within R - 2 d at
// positions X each within d of a rigid motion of P (X_i within d of R P_i + t), since moving
// every point of two primitives by at most d changes their distance by at most 2 d and a rigid
// motion changes none; along a step from xa to xb, both ends within d of the same motion, every
// position between is too. So a call looks first at how far its positions are from the best
// rigid motion of the kept ones (Kabsch's fit), and takes the kept regions when that bound
// allows; otherwise it finds the regions anew and keeps them with the largest reach at which
// they all pass (each region's cone and altitude bound, and its contour's distances measured out
// to a few times the widest reach asked). Taking kept regions changes no pair found, only the time
// spent.
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
  long reused = 0;             ///< calls that took the regions kept from an earlier call
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

  /// Keeps no regions between calls (each call finds its own; for tests and benchmarks).
  void set_keeping(bool on) {
    keeping_ = on;
    kept_.valid = false;
  }

 private:
  // The cones of every node of the tree over the step from xa to xb.
  void find_cones(const std::vector<std::array<int, 3>>& triangles, const AabbTree& tree, const VecX& xa,
                  const VecX& xb, bool moving);
  // The top-most regions that pass at reach r, flagged in skip (resized and cleared); returns
  // the largest reach at which they all pass (at least r; 0 if none passes).
  double select(const AabbTree& tree, const VecX& xa, const VecX& xb, bool moving, double r, std::vector<char>& skip);
  // Whether every vertex of xa (and of xb, moving) lies within d of the kept positions, or of the
  // rigid motion of them that best fits xa.
  bool near_kept(const VecX& xa, const VecX& xb, bool moving, double d) const;
  // How far apart condition 3 finds the contour's segments (the least of its distances, as
  // times kSafety, out to kKeptProbe times the widest reach asked); 0 when it fails at r.
  double contour_clearance(int node, const Vec3& axis, const VecX& xa, const VecX& xb, bool moving, double r);

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

  // Regions kept from an earlier call: they hold no pair within `reach` at `positions`.
  struct Kept {
    bool valid = false;
    VecX positions;
    Vec3 centroid = Vec3::Zero();
    double reach = 0;
    std::vector<char> skip;
    long triangles = 0;  ///< held by the regions in skip
  };
  Kept kept_;
  bool keeping_ = true;
  double widest_r_ = 0;  ///< the widest reach asked so far
  SelfCullingStatistics stats_;
};

}  // namespace weft
