#pragma once
// A sewing pattern's panels meshed for simulation (docs/patterns.md, "Meshing a pattern"):
// every edge sampled at the target length with both sides of each stitch given the same
// count, each panel's outline meshed with those points kept as its boundary, and each
// stitch's two sides matched vertex by vertex.
//
// Coordinates are each panel's own pattern coordinates (metres, x right, y up, as the pattern
// file gives them). Placing the panels around a body and sewing them come later.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "weft/garment/pattern.hpp"
#include "weft/types.hpp"

namespace weft {

struct GarmentMeshOptions {
  double target_edge_m = 0.015;  ///< outline segment length and interior edge length aimed at (m)
  double min_angle_deg = 25;     ///< smallest angle the mesher aims at, in (0, 34]
  /// Grain per panel name (radians, counter-clockwise from the pattern's y axis to the warp);
  /// panels not named have their warp along y. The pattern files carry no grain line.
  std::map<std::string, double> grain_angle_rad;
};

struct GarmentPanelMesh {
  std::string name;                           ///< the panel's name in the pattern
  std::vector<Vec2> vertices_m;               ///< #V pattern coordinates (m)
  std::vector<std::array<int, 3>> triangles;  ///< #F vertex indices, counter-clockwise
  /// The first boundary_vertices vertices are the panel's sampled outline, counter-clockwise
  /// (SampledOutline::points_m, bit for bit); interior vertices follow.
  int boundary_vertices = 0;
  /// For each panel edge (in the panel's edge order): its segments + 1 vertex indices from the
  /// edge's start to its end, whichever way the outline runs. Neighbouring edges share their
  /// corner vertex.
  std::vector<std::vector<int>> edge_vertices;
  /// Angle (radians, counter-clockwise) from the pattern's y axis to the warp (the grain line):
  /// GarmentMeshOptions::grain_angle_rad, 0 (the warp along y) by default.
  double grain_angle_rad = 0;
};

/// One stitch's matched vertices: pairs[k] = {vertex of panel_a, vertex of panel_b} are sewn
/// together. Side a runs along its edge from the edge's start; side b from its end (a stitch
/// of right side to right side) or its start (Stitch::same_direction), as sample_stitch.
struct StitchVertexPairs {
  int panel_a = 0, edge_a = 0;  ///< indices into Pattern::panels and that panel's edges
  int panel_b = 0, edge_b = 0;
  std::vector<std::array<int, 2>> pairs;  ///< segments + 1 pairs
};

struct GarmentMesh {
  std::vector<GarmentPanelMesh> panels;     ///< in Pattern::panels order
  std::vector<StitchVertexPairs> stitches;  ///< in Pattern::stitches order
  EdgeSegmentCounts segment_counts;         ///< the counts the outlines were sampled with
};

/// Meshes every panel of the pattern. Throws InputError for bad options (a grain for a panel
/// the pattern lacks, or not finite), or when a panel
/// cannot be meshed (its outline sampled at the target crosses itself, or it needs more
/// vertices than the mesher allows); the message names the pattern file and the panel:
/// "FILE: panel 'NAME': meshing at 0.015 m: ...".
GarmentMesh mesh_garment(const Pattern& pattern, const GarmentMeshOptions& options = {});

/// The unit warp and weft directions of a panel in its pattern coordinates: warp is the y
/// axis turned by grain_angle_rad, weft is warp turned clockwise by 90 degrees (x at angle 0).
Vec2 warp_direction(const GarmentPanelMesh& panel);
Vec2 weft_direction(const GarmentPanelMesh& panel);
/// #V material coordinates (u along the weft, v along the warp, metres), as TriMesh::pattern
/// holds them: the pattern coordinates themselves at grain angle 0.
std::vector<Vec2> material_coordinates(const GarmentPanelMesh& panel);

/// Offsets that lay the panels flat side by side without overlap: panel p drawn at
/// vertices_m + offsets[p]. Panels go left to right in rows (in pattern order) separated by
/// gap_m, a row ending once it is wider than 1.6 times the square root of the panels' total
/// bounding-box area; the first row at the top, the whole layout's bounding box from (0, 0).
std::vector<Vec2> flat_layout_offsets(const GarmentMesh& mesh, double gap_m = 0.05);

/// Quality figures of one meshed panel.
struct PanelMeshStats {
  double area_m2 = 0;             ///< sum of the triangles' areas
  double smallest_angle_deg = 0;  ///< over all triangles
  double mean_edge_m = 0;         ///< mean length of the mesh's edges (each counted once)
};
PanelMeshStats panel_mesh_stats(const GarmentPanelMesh& panel);

}  // namespace weft
