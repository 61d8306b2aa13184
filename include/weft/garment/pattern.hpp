#pragma once
// Sewing patterns: the JSON specifications of GarmentCode and Garment-Pattern-Generator
// (docs/patterns.md), their edge curves, and the sampling of those curves into the points
// that panel outlines and stitches share.
//
// Coordinates are in metres in each panel's own plane (x right, y up). An edge is sampled at
// points of equal arc length; an edge is always sampled by the same function from its own
// start to its own end, so a panel outline and a stitch built from the same segment counts
// hold the very same points.
#include <array>
#include <string>
#include <vector>

#include "weft/types.hpp"

namespace weft {

enum class CurveKind { kStraight, kQuadratic, kCubic, kArc };

/// The geometry of one panel edge, from `start` to `end` (metres, panel plane).
struct EdgeCurve {
  CurveKind kind = CurveKind::kStraight;
  Vec2 start = Vec2::Zero();
  Vec2 end = Vec2::Zero();
  /// Bezier control points in panel coordinates: quadratic uses [0], cubic [0] and [1].
  std::array<Vec2, 2> control = {Vec2::Zero(), Vec2::Zero()};
  /// Arcs: centre, radius, angle of `start` seen from the centre, and the signed angle swept
  /// from start to end (positive: counter-clockwise), |sweep| in (0, 2 pi).
  Vec2 center = Vec2::Zero();
  double radius_m = 0;
  double start_angle_rad = 0;
  double sweep_rad = 0;
};

struct PanelEdge {
  int start_vertex = 0;  ///< index into Panel::vertices_m
  int end_vertex = 0;
  EdgeCurve curve;
};

struct Panel {
  std::string name;
  std::vector<Vec2> vertices_m;  ///< the corners, as the file lists them
  /// In file order: edge i ends where edge i+1 starts, and the last ends where the first starts.
  std::vector<PanelEdge> edges;
  /// True when the file's edge loop runs clockwise in the panel plane. The loop's direction
  /// gives the panel's outward side (right-hand rule): +z of the panel plane for a
  /// counter-clockwise loop, -z for a clockwise one. Outlines are always counter-clockwise.
  bool clockwise = false;
  Vec3 translation_m = Vec3::Zero();  ///< 3D placement from the file (for another body)
  Vec3 rotation_deg = Vec3::Zero();   ///< XYZ Euler angles in degrees, as the file gives them
};

/// One side of a stitch: an edge of a panel.
struct StitchSide {
  int panel = 0;  ///< index into Pattern::panels
  int edge = 0;   ///< index into Panel::edges
};

/// Two panel edges sewn together. By default (right side of the fabric to right side) the two
/// edges run in opposite directions: a's start meets b's end. A "right_wrong" stitch joins
/// them in the same direction: a's start meets b's start.
struct Stitch {
  StitchSide a, b;
  bool same_direction = false;
};

struct Pattern {
  std::string name;           ///< file name without folder, ".json" and "_specification"
  std::string file;           ///< the file as given to load_pattern (names it in messages)
  std::vector<Panel> panels;  ///< in `panel_order` when the file has one, else by name
  std::vector<Stitch> stitches;
};

/// Reads a pattern file. Throws InputError naming the file, the panel and the edge for a
/// malformed file, a stitch naming a missing panel or edge, an edge loop that is not closed,
/// or a panel whose outline crosses itself ("FILE: panel 'NAME': edge 3: curvature: ...").
/// Keys the formats carry for other uses (parameters, labels, constraints) are ignored.
Pattern load_pattern(const std::string& path);
/// The same from JSON text; `file` names it in messages and gives Pattern::name.
Pattern parse_pattern(const std::string& text, const std::string& file);

struct Scene;
/// Checks that every panel the scene's garment names (cloth.mesh.pattern.panels) is one of
/// `pattern`'s (the scene's reader reads no pattern). Throws InputError naming the scene's file
/// (or "scene"), the key and the pattern: "SCENE: key cloth.mesh.pattern.panels.NAME: the
/// pattern FILE has no panel 'NAME'". A scene without a garment passes.
void check_scene_panels(const Scene& scene, const Pattern& pattern);

// ---- curves ----

/// The point at parameter t in [0, 1] (the curve's own parameter, not arc length).
Vec2 curve_point(const EdgeCurve& curve, double t);
/// Exact length for straight edges and arcs (r |sweep|); Bezier lengths by adaptive
/// Gauss-Legendre quadrature, converged to about 1e-13 of the control polygon's length.
double curve_length_m(const EdgeCurve& curve);
/// Segments an edge gets at a target segment length: ceil(length / target), at least 1.
/// Throws std::invalid_argument unless the target is positive.
int segment_count(const EdgeCurve& curve, double target_length_m);
/// segments + 1 points at equal arc length along the curve, from start to end (both exact
/// copies of the curve's endpoints). Requires segments >= 1.
std::vector<Vec2> sample_curve(const EdgeCurve& curve, int segments);

// ---- outlines and stitches ----

/// Segment counts of every edge: counts[panel][edge].
using EdgeSegmentCounts = std::vector<std::vector<int>>;

/// Each edge's segment_count at the target length, raised so that both sides of every stitch
/// have the same count (the largest among edges joined through stitches).
EdgeSegmentCounts edge_segment_counts(const Pattern& pattern, double target_length_m);

/// Where an edge's points sit in its panel's outline: outline vertices
/// (first + k) mod #points for k = 0..segments. When the panel is clockwise (the outline
/// runs against the file's edges) k = 0 is the edge's end, otherwise its start.
struct EdgeSpan {
  int first = 0;
  int segments = 0;
};

struct SampledOutline {
  /// The closed polygon, counter-clockwise, each point once (no repeat of the first).
  std::vector<Vec2> points_m;
  std::vector<EdgeSpan> edges;  ///< one per panel edge, in the panel's edge order
  bool reversed = false;        ///< the panel is clockwise, so its edges run backwards here
};

/// The outline of a panel with `segments[e]` segments on edge e (size = #edges).
SampledOutline panel_outline(const Panel& panel, const std::vector<int>& segments);
/// Every panel's outline with the given counts.
std::vector<SampledOutline> pattern_outlines(const Pattern& pattern, const EdgeSegmentCounts& counts);

/// Signed area of a closed polygon (positive when counter-clockwise), m^2.
double polygon_area_m2(const std::vector<Vec2>& polygon);
/// A pair of segments of the closed polygon that cross or touch (other than neighbours at
/// their shared point), as indices of their first points, or {-1, -1} when it is simple.
std::array<int, 2> polygon_self_intersection(const std::vector<Vec2>& polygon);

/// The two sides of a stitch as matching point lists: a[k] is sewn to b[k]. `a` runs along
/// side a's edge from its start; `b` along side b's edge from its end (opposite stitch) or
/// its start (same_direction). Both have segments + 1 points.
struct StitchPoints {
  std::vector<Vec2> a, b;
};
/// Sampled with counts from edge_segment_counts (the same points as the outlines).
StitchPoints sample_stitch(const Pattern& pattern, const Stitch& stitch, const EdgeSegmentCounts& counts);
/// Sampled with the larger of the two sides' segment_count at the target length.
StitchPoints sample_stitch(const Pattern& pattern, const Stitch& stitch, double target_length_m);

}  // namespace weft
