#pragma once
// Placing a meshed sewing pattern around the mannequin in its bind pose (docs/garments.md,
// "Placement"): each panel is rolled, without stretching, onto a cylinder about a part of the
// body (the torso, an arm, a leg, the head) at a clearance, on the side its own placement in
// the pattern file faces; then the panels become one mesh whose seams are the stitches' vertex
// pairs.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "weft/garment/garment_mesh.hpp"
#include "weft/mesh.hpp"
#include "weft/body.hpp"
#include "weft/placement_spec.hpp"

namespace weft {


struct PlacementOptions {
  double clearance_m = 0.02;  ///< gap between the body and the cylinders the panels lie on
  /// The cylinders' girth is at least this factor times the widths of the panels around them
  /// summed, so that panels side by side leave a small gap at their seams.
  double girth_allowance = 1.05;
  std::map<std::string, PanelPlacementOverride> overrides;  ///< by panel name
};

/// The body the garment is placed on: the mannequin standing in its bind pose (the T-pose)
/// where a walk starts.
struct BindBody {
  Points positions;  ///< #V by 3 (m)
  Triangles triangles;
  Rig rig;           ///< head_bind and tail_bind moved with the body
  BodyColliderSpec spec;  ///< the body as a scene collider, standing still in that pose
  /// The same body with each leg turned kLegsApartDeg away from the other about the forward
  /// axis at its hip (the feet apart): trousers are placed and sewn on it, the legs then
  /// brought back together while the cloth follows (docs/garments.md, "Placement" and "Sewing").
  Points legs_apart_positions;
  Rig legs_apart_rig;
};
/// How far each leg turns out for trousers (degrees).
inline constexpr double kLegsApartDeg = 12.0;
/// The mannequin of a scene's body collider at time 0, held in its bind pose for `hold_s`
/// seconds (spec.bind_pose_hold is raised to it): the bind pose moved to where the motion
/// starts, as the walk scenes have it while the garment settles. hold_s must be positive.
BindBody load_bind_body(BodyColliderSpec spec, double hold_s);

/// One garment mesh made of all the panels, placed.
struct PlacedGarment {
  /// Positions placed around the body; pattern = the panels laid out flat side by side
  /// (flat_layout_offsets), panels mirrored where the file's loop is clockwise so that
  /// every triangle's normal (counter-clockwise in the pattern) faces away from the body.
  TriMesh mesh;
  std::vector<int> panel_first_vertex;  ///< panel p's vertices start here (#panels + 1 entries)
  std::vector<int> panel_of_triangle;   ///< #F
  std::vector<BodyPart> panel_part;     ///< the part each panel was wrapped around
  /// Vertex pairs to sew (both sides of every stitch, global indices), each pair once.
  std::vector<std::array<int, 2>> seam_pairs;
  std::vector<int> seam_stitch;          ///< the stitch of each pair (index into Pattern::stitches)
  int vertices_pushed_out = 0;           ///< placed too near the body and moved out
  /// Placed on the body with its legs apart (trousers: BindBody::legs_apart_positions); sewing
  /// brings the legs back to the bind pose.
  bool legs_apart = false;
  /// Times a panel was moved around its part, away from a panel it met edge on edge, to leave
  /// a 6 mm gap (the two fronts of an open jacket).
  int panels_moved_apart = 0;
};

/// Places every panel. Throws InputError naming the pattern file and the panel when a panel
/// cannot be rolled onto its part's cylinder (it faces along the axis) or an override names
/// a panel the pattern lacks.
PlacedGarment place_garment(const Pattern& pattern, const GarmentMesh& mesh, const BindBody& body,
                            const PlacementOptions& options = {});

/// The largest distance between the two vertices of a seam pair (m).
double largest_seam_gap(const Points& positions, const std::vector<std::array<int, 2>>& pairs);

}  // namespace weft
