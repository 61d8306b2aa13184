#pragma once
// Sewing a placed garment on the bind-pose body (docs/garments.md, "Sewing"): zero-length
// springs pull every stitch's vertex pairs together while the cloth, without gravity, keeps
// off the body; once the largest seam gap is small, the pairs are welded into single vertices,
// so the garment is one mesh whose bending runs across its seams.
#include <array>
#include <string>
#include <vector>

#include "weft/frame_check.hpp"
#include "weft/garment/placement.hpp"
#include "weft/material.hpp"

namespace weft {

struct SewingOptions {
  Material material;            ///< the fabric during sewing
  /// Per panel (Pattern::panels order): its fabric during sewing; empty: `material` for all.
  std::vector<Material> panel_materials;
  double seam_stiffness_N_m = 1e4;  ///< each seam pair's spring
  double dt_s = 0.005;          ///< backward Euler step
  double interval_s = 0.02;     ///< velocities are zeroed after each interval (quasi-static)
  double max_time_s = 1.0;      ///< gives up sewing after this simulated time (or once the gap stops shrinking)
  double gap_m = 0.0005;        ///< sewing stops once every seam pair is this close
  double body_thickness_m = 0.003;  ///< the clearance the body collider keeps
  bool self_collision = true;
};

/// A sewn garment: one welded mesh.
struct SewnGarment {
  /// Seam vertices merged (their mean position); corner_pattern holds each triangle's flat
  /// panel coordinates, `pattern` one of each vertex's.
  TriMesh mesh;
  std::vector<int> panel_of_triangle;  ///< #F
  std::vector<int> welded_vertex;      ///< the placed mesh's vertex -> the welded mesh's vertex
  Points sewn_positions;               ///< the placed mesh's vertices when sewing stopped
  double largest_gap_m = 0;            ///< over the seam pairs when sewing stopped (before welding)
  double largest_gap_placed_m = 0;     ///< over the seam pairs as placed
  double sewing_time_s = 0;            ///< simulated seconds of sewing
  int steps = 0;
  bool converged = false;              ///< the gap came under SewingOptions::gap_m
  FrameIntersections intersections;    ///< of the welded garment, with itself and the body
};

/// Sews and welds. `progress(time_s, gap_m)` is called after each interval when given.
SewnGarment sew_garment(const PlacedGarment& placed, const BindBody& body, const SewingOptions& options,
                        const std::function<void(double, double)>& progress = {});

/// Welds the placed mesh's seam pairs without sewing (positions averaged as they are).
SewnGarment weld_seams(const PlacedGarment& placed, const Points& positions);

/// Edges of a triangle mesh by how many triangles use them.
struct EdgeUse {
  int boundary = 0;      ///< used once (the garment's openings)
  int interior = 0;      ///< used twice
  int non_manifold = 0;  ///< used three times or more
  int inconsistent = 0;  ///< used twice in the same direction (the two triangles disagree on orientation)
};
EdgeUse edge_use(const std::vector<std::array<int, 3>>& triangles);

}  // namespace weft
