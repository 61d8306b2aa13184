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
// Always: the mesh covers the panel exactly, triangles are counter-clockwise, every interior
// edge is constrained Delaunay, and the refinement ends. Quality (split_boundary = false), as
// the tests check it on outlines sampled at 0.6 to 1.3 target_edge_m: every triangle has
// circumradius at most 0.75 target_edge_m, or 0.6 times the longest boundary segment it stands
// on if that is more (edges come out about target_edge_m long), and its smallest angle is at
// least min_angle_deg except
//  - triangles with that angle at an input corner whose interior angle is below 60 degrees
//    (such a corner cannot always be split into angles above the target, so they are left),
//  - triangles joining outline points only, where the panel is narrower than the target
//    (there is no room for an interior point), and
//  - triangles along boundary segments longer than about 1.3 target_edge_m, where no interior
//    point makes a good triangle with the segment (their size can exceed the bound too).
// With split_boundary = true the mesher also splits boundary segments whose diametral circle
// holds a circumcentre (Ruppert, down to 0.2 target_edge_m), so triangles along long segments
// reach the angle and size too. docs/panel-meshing.md gives the measured figures.
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
