#pragma once
// Quality triangulation of flat garment panels: a constrained Delaunay triangulation of the
// panel's outline refined by inserting circumcentres of bad triangles (Delaunay refinement in
// the manner of Ruppert and Chew), written for weft.
//
// By default the outline's points and segments are kept exactly: the pattern code samples
// both sides of every stitch with the same number of points, so the mesher adds no point on
// the boundary. Where a circumcentre would fall outside the panel or too close to a boundary
// segment, the mesher inserts instead the apex of a well-shaped triangle standing on that
// segment, or leaves the triangle as it is.
//
// Guarantee (split_boundary = false): every triangle has circumradius at most about
// 0.7 target_edge_m (edges about target_edge_m long), and its smallest angle is at least
// min_angle_deg except
//  - at an input corner whose interior angle is below 60 degrees (such a corner cannot always
//    be split into angles above the target, so triangles with their smallest angle there are
//    left), and
//  - next to boundary segments much shorter or longer than target_edge_m, or on segments too
//    close to other parts of the outline, where no interior point makes a good triangle.
// With split_boundary = true the mesher also splits boundary segments whose diametral circle
// holds a circumcentre (Ruppert), so near-boundary triangles can reach the angle too.
#include <array>
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// A flat panel in its pattern coordinates (m).
struct PanelOutline {
  /// #P outer boundary points, counter-clockwise (clockwise is accepted too), no repeated
  /// closing point. Segment i joins point i and point (i + 1) % #P.
  std::vector<Vec2> outer;
  /// Each hole's points, in either orientation, no repeated closing point. A hole lies inside
  /// the outer boundary and outside every other hole, touching neither.
  std::vector<std::vector<Vec2>> holes;
};

struct PanelMeshOptions {
  double target_edge_m = 0.015;  ///< interior edge length aimed at (m)
  double min_angle_deg = 25;     ///< smallest angle aimed at, in (0, 34]
  /// false: the outline's points and segments are the mesh boundary, exactly. true: boundary
  /// segments may be split (the new boundary points follow the outline's points).
  bool split_boundary = false;
  int max_vertices = 2000000;  ///< more vertices needed than this is an InputError
};

struct PanelMesh {
  std::vector<Vec2> vertices;                 ///< #V points (m)
  std::vector<std::array<int, 3>> triangles;  ///< #F vertex indices, counter-clockwise
  /// The first boundary_vertices vertices are the outline's points in input order: the outer
  /// boundary, then each hole in turn. Points added by refinement follow.
  int boundary_vertices = 0;
};

/// Triangulates the panel. Throws weft::InputError for an outline with fewer than 3 points in
/// a ring, repeated or non-finite points, zero area, crossing or touching segments, a hole
/// outside the outer boundary or inside another hole, bad options, or more than max_vertices
/// vertices needed; the message names the ring and point index.
PanelMesh mesh_panel(const PanelOutline& outline, const PanelMeshOptions& options = {});

}  // namespace weft
