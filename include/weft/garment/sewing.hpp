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
  /// The most a vertex moves in one sewing step (IntegratorSettings::max_step_motion): seams
  /// placed tens of centimetres apart close over several steps instead of one, so that the
  /// contacts' search over each step's motion stays short.
  double max_step_motion_m = 0.02;
  /// The largest seam gap the weld closes: a stitch whose pairs are farther apart than this
  /// when sewing stops is left open (not welded), and the garment is not sewn. At 5 mm each
  /// side of a seam moves at most 2.5 mm in the weld, a sixth of a 1.5 cm edge.
  double weld_gap_m = 0.005;
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
  /// The gap came under SewingOptions::gap_m while sewing (sewing stopped for that reason);
  /// a garment that stopped for another reason may still have every seam within the weld's
  /// reach: `sewn()` says whether the garment came out whole.
  bool converged = false;
  /// Per stitch (index into Pattern::stitches): the largest gap of its vertex pairs when
  /// sewing stopped (m). Stitches past the end, or with no pair of their own, have none (0).
  std::vector<double> stitch_gap_m;
  double weld_gap_m = 0;               ///< SewingOptions::weld_gap_m, the gap the weld closes
  /// Stitches whose gap is above weld_gap_m, in stitch order: not welded, left open in `mesh`.
  std::vector<int> open_stitches;
  FrameIntersections intersections;    ///< of the welded garment (`mesh`), with itself and the body
  /// Every stitch welded and the welded garment free of intersections with itself and the body.
  bool sewn() const { return open_stitches.empty() && intersections.count() == 0; }
};

/// Sews and welds. `progress(time_s, gap_m)` is called after each interval when given.
SewnGarment sew_garment(const PlacedGarment& placed, const BindBody& body, const SewingOptions& options,
                        const std::function<void(double, double)>& progress = {});

/// Welds the placed mesh's seam pairs without sewing (positions averaged as they are), all
/// but those of the stitches in `open_stitches` (Pattern::stitches indices), which stay apart.
SewnGarment weld_seams(const PlacedGarment& placed, const Points& positions,
                       const std::vector<int>& open_stitches = {});

/// A garment's intersecting triangle pairs with itself and with the body (FrameChecker).
FrameIntersections garment_intersections(const TriMesh& mesh, const BindBody& body);

/// What keeps `sewn` from being sewn, as the lines of a message, each ending in a newline:
/// one per open stitch ("  stitch 4 (panel 'hood' edge 2 to panel 'front' edge 5): gap
/// 155.96 mm"), then the intersections left. Empty for a sewn garment.
std::string unsewn_report(const Pattern& pattern, const SewnGarment& sewn);

/// The one-line headline of an unsewn garment: "PATTERN did not sew: 3 of 18 stitches left
/// open (their gap above the weld's 5 mm after 0.30 s of sewing), 11 intersections with
/// itself, 107 with the body".
std::string unsewn_headline(const Pattern& pattern, const SewnGarment& sewn);

/// Edges of a triangle mesh by how many triangles use them.
struct EdgeUse {
  int boundary = 0;      ///< used once (the garment's openings)
  int interior = 0;      ///< used twice
  int non_manifold = 0;  ///< used three times or more
  int inconsistent = 0;  ///< used twice in the same direction (the two triangles disagree on orientation)
};
EdgeUse edge_use(const std::vector<std::array<int, 3>>& triangles);

}  // namespace weft
