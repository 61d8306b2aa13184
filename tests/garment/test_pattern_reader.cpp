// The sewing-pattern reader: edge forms, units, stitches, outlines, and refused files.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "weft/garment/pattern.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

using nlohmann::json;

/// A unit square panel (in file units), edges counter-clockwise from the origin.
json square_panel() {
  return json{{"vertices", {{0, 0}, {1, 0}, {1, 1}, {0, 1}}},
              {"edges", {{{"endpoints", {0, 1}}}, {{"endpoints", {1, 2}}}, {{"endpoints", {2, 3}}}, {{"endpoints", {3, 0}}}}},
              {"translation", {0, 0, 0}},
              {"rotation", {0, 0, 0}}};
}

/// A pattern file with the given panels, in metres.
json pattern_file(const json& panels, const json& stitches = json::array()) {
  return json{{"pattern", {{"panels", panels}, {"stitches", stitches}}},
              {"properties", {{"curvature_coords", "relative"}, {"units_in_meter", 1}}}};
}

Pattern parse(const json& j) { return parse_pattern(j.dump(), "t.json"); }

std::string error_of(const json& j) {
  try {
    parse(j);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

json stitch(const char* panel_a, int edge_a, const char* panel_b, int edge_b) {
  return json::array({{{"panel", panel_a}, {"edge", edge_a}}, {{"panel", panel_b}, {"edge", edge_b}}});
}

TEST(PatternReader, RelativeControlPointIsAlongAndLeftOfTheEdge) {
  // The top edge runs from (1, 1) to (0, 1): along = (-1, 0), its left = (0, -1).
  json panel = square_panel();
  panel["edges"][2]["curvature"] = {0.25, 0.2};
  const Pattern p = parse(pattern_file({{"front", panel}}));
  const EdgeCurve& c = p.panels[0].edges[2].curve;
  ASSERT_EQ(c.kind, CurveKind::kQuadratic);
  EXPECT_NEAR((c.control[0] - Vec2(0.75, 0.8)).norm(), 0, 1e-15);

  // GarmentCode's object forms: quadratic and cubic with the same relative coordinates.
  panel["edges"][2]["curvature"] = {{"type", "quadratic"}, {"params", {{0.25, 0.2}}}};
  EXPECT_NEAR((parse(pattern_file({{"front", panel}})).panels[0].edges[2].curve.control[0] - Vec2(0.75, 0.8)).norm(), 0,
              1e-15);
  panel["edges"][2]["curvature"] = {{"type", "cubic"}, {"params", {{0.25, 0.2}, {0.5, -0.1}}}};
  const EdgeCurve cu = parse(pattern_file({{"front", panel}})).panels[0].edges[2].curve;
  ASSERT_EQ(cu.kind, CurveKind::kCubic);
  EXPECT_NEAR((cu.control[0] - Vec2(0.75, 0.8)).norm(), 0, 1e-15);
  EXPECT_NEAR((cu.control[1] - Vec2(0.5, 1.1)).norm(), 0, 1e-15);
}

TEST(PatternReader, CircleArcsFollowRadiusAndFlags) {
  // The bottom edge (0, 0) -> (1, 0) as an arc; "right" bulges to -y (outside the square).
  const double r = std::sqrt(0.5);
  struct Case {
    double radius;
    int large, right;
    double sweep;       // expected signed sweep
    double mid_y;       // expected y of the arc's middle
  };
  const Case cases[] = {
      {0.5, 0, 1, M_PI, -0.5},                         // half circle below
      {r, 0, 1, M_PI / 2, -(r - 0.5)},                 // quarter circle below
      {r, 1, 1, 3 * M_PI / 2, -(0.5 + r)},             // three quarters below
      {r, 0, 0, -M_PI / 2, r - 0.5},                   // quarter circle above (inside)
  };
  for (const Case& k : cases) {
    json panel = square_panel();
    panel["edges"][0]["curvature"] = {{"type", "circle"}, {"params", {k.radius, k.large, k.right}}};
    const EdgeCurve c = parse(pattern_file({{"front", panel}})).panels[0].edges[0].curve;
    ASSERT_EQ(c.kind, CurveKind::kArc);
    EXPECT_NEAR(c.sweep_rad, k.sweep, 1e-12);
    EXPECT_NEAR(curve_length_m(c), k.radius * std::abs(k.sweep), 1e-12);
    EXPECT_NEAR((curve_point(c, 0) - Vec2(0, 0)).norm(), 0, 1e-12);
    EXPECT_NEAR((curve_point(c, 1) - Vec2(1, 0)).norm(), 0, 1e-12);
    const Vec2 mid = curve_point(c, 0.5);
    EXPECT_NEAR(mid.x(), 0.5, 1e-12);
    EXPECT_NEAR(mid.y(), k.mid_y, 1e-12);
  }
}

TEST(PatternReader, UnitsPlacementAndUnknownKeys) {
  json panel = square_panel();
  panel["vertices"] = {{0, 0}, {300, 0}, {300, 150}, {0, 150}};
  panel["translation"] = {30, -60, 90};
  panel["rotation"] = {0, 180, 10};
  panel["label"] = "body";                   // GarmentCode's extras are ignored
  panel["edges"][1]["label"] = "side";
  panel["edges"][0]["curvature"] = {{"type", "circle"}, {"params", {300, 0, 1}}};
  json file = pattern_file({{"front", panel}});
  file["properties"]["units_in_meter"] = 300;
  file["parameters"] = json::object();       // Garment-Pattern-Generator's template data
  file["parameter_order"] = json::array();
  const Pattern p = parse(file);
  ASSERT_EQ(p.panels.size(), 1u);
  const Panel& front = p.panels[0];
  EXPECT_EQ(front.name, "front");
  EXPECT_NEAR((front.vertices_m[2] - Vec2(1, 0.5)).norm(), 0, 1e-15);
  EXPECT_NEAR((front.translation_m - Vec3(0.1, -0.2, 0.3)).norm(), 0, 1e-15);
  EXPECT_EQ(front.rotation_deg, Vec3(0, 180, 10));
  EXPECT_NEAR(front.edges[0].curve.radius_m, 1.0, 1e-15);  // radii are lengths too
  EXPECT_FALSE(front.clockwise);
}

TEST(PatternReader, AbsoluteControlPointsAndNormalizedTranslation) {
  json panel = square_panel();
  panel["vertices"] = {{100, 0}, {300, 0}, {300, 100}, {100, 100}};
  panel["translation"] = {10, 20, 30};
  panel["edges"][0]["curvature"] = {200, -50};
  json file = pattern_file({{"front", panel}});
  file["properties"] = {{"curvature_coords", "absolute"}, {"units_in_meter", 100}, {"normalize_panel_translation", true}};
  const Panel front = parse(file).panels[0];
  // The corners' mean (2, 0.5) m moves to the origin and into the translation's x and y.
  EXPECT_NEAR((front.vertices_m[0] - Vec2(-1, -0.5)).norm(), 0, 1e-15);
  EXPECT_NEAR((front.translation_m - Vec3(2.1, 0.7, 0.3)).norm(), 0, 1e-15);
  // An absolute control point is a point of the panel, moved with it.
  EXPECT_NEAR((front.edges[0].curve.control[0] - Vec2(0, -1)).norm(), 0, 1e-15);
}

TEST(PatternReader, PanelOrderAndNames) {
  json file = pattern_file({{"b", square_panel()}, {"a", square_panel()}, {"c", square_panel()}});
  EXPECT_EQ(parse(file).panels[0].name, "a");  // no panel_order: by name
  file["pattern"]["panel_order"] = {"c", "a", "b"};
  const Pattern p = parse(file);
  EXPECT_EQ(p.panels[0].name, "c");
  EXPECT_EQ(p.panels[2].name, "b");
  EXPECT_EQ(parse_pattern(file.dump(), "dir/shirt_mean_specification.json").name, "shirt_mean");

  file["pattern"]["panel_order"] = {"c", "a"};
  EXPECT_EQ(error_of(file), "t.json: key pattern.panel_order: panel 'b' is missing from the order");
}

TEST(PatternReader, ClockwisePanelGivesCounterClockwiseOutline) {
  json panel = square_panel();
  panel["edges"] = {{{"endpoints", {0, 3}}}, {{"endpoints", {3, 2}}}, {{"endpoints", {2, 1}}},
                    {{"endpoints", {1, 0}}, {"curvature", {0.5, 0.25}}}};
  const Pattern p = parse(pattern_file({{"back", panel}}));
  const Panel& back = p.panels[0];
  EXPECT_TRUE(back.clockwise);
  const std::vector<int> segments = {2, 3, 4, 5};
  const SampledOutline out = panel_outline(back, segments);
  EXPECT_TRUE(out.reversed);
  ASSERT_EQ(out.points_m.size(), 14u);
  EXPECT_GT(polygon_area_m2(out.points_m), 0);
  // Each edge's samples appear backwards from its span's first point.
  for (size_t e = 0; e < back.edges.size(); ++e) {
    const std::vector<Vec2> pts = sample_curve(back.edges[e].curve, segments[e]);
    ASSERT_EQ(out.edges[e].segments, segments[e]);
    for (int k = 0; k <= segments[e]; ++k)
      EXPECT_EQ(out.points_m[static_cast<size_t>((out.edges[e].first + k) % 14)], pts[static_cast<size_t>(segments[e] - k)])
          << "edge " << e << " point " << k;
  }
}

TEST(PatternReader, StitchDirectionsAndSharedCounts) {
  // Three squares in a row: a's right edge to b's curved left edge, b's right edge to c's
  // left edge (right side to wrong side).
  json a = square_panel(), b = square_panel(), c = square_panel();
  b["edges"][3]["curvature"] = {0.5, 0.3};
  json stitches = json::array({stitch("a", 1, "b", 3), stitch("b", 1, "c", 3)});
  stitches[1].push_back("right_wrong");
  const Pattern p = parse(pattern_file({{"a", a}, {"b", b}, {"c", c}}, stitches));
  ASSERT_EQ(p.stitches.size(), 2u);
  EXPECT_FALSE(p.stitches[0].same_direction);
  EXPECT_TRUE(p.stitches[1].same_direction);

  const double target = 0.1;
  const int curved = segment_count(p.panels[1].edges[3].curve, target);
  ASSERT_GT(curved, 10);  // the bulging edge is longer than the straight ones
  const EdgeSegmentCounts counts = edge_segment_counts(p, target);
  EXPECT_EQ(counts[0][1], curved);  // raised to its curved partner's count
  EXPECT_EQ(counts[1][3], curved);
  EXPECT_EQ(counts[1][1], 10);      // straight to straight: ceil(1 / 0.1)
  EXPECT_EQ(counts[2][3], 10);
  EXPECT_EQ(counts[0][0], 10);      // unstitched edges keep their own count

  // Opposite directions: a's start meets b's end. Same direction: start meets start.
  const StitchPoints s0 = sample_stitch(p, p.stitches[0], counts);
  ASSERT_EQ(s0.a.size(), s0.b.size());
  EXPECT_EQ(s0.a.front(), p.panels[0].edges[1].curve.start);
  EXPECT_EQ(s0.b.front(), p.panels[1].edges[3].curve.end);
  const StitchPoints s1 = sample_stitch(p, p.stitches[1], counts);
  EXPECT_EQ(s1.a.front(), p.panels[1].edges[1].curve.start);
  EXPECT_EQ(s1.b.front(), p.panels[2].edges[3].curve.start);
  // With a target length alone, the larger side's count.
  EXPECT_EQ(sample_stitch(p, p.stitches[0], target).a.size(), static_cast<size_t>(curved + 1));
}

// ---- refused files: exact messages ----

TEST(PatternReader, RefusesStitchesNamingMissingPanelsOrEdges) {
  const json panels = {{"front", square_panel()}, {"back", square_panel()}};
  EXPECT_EQ(error_of(pattern_file(panels, json::array({stitch("front", 1, "back", 7)}))),
            "t.json: key pattern.stitches[0][1].edge: panel 'back' has no edge 7 (its edges are 0 to 3)");
  EXPECT_EQ(error_of(pattern_file(panels, json::array({stitch("front", 1, "back", 3), stitch("frnt", 0, "back", 1)}))),
            "t.json: key pattern.stitches[1][0].panel: no panel named 'frnt'");
  json flagged = stitch("front", 1, "back", 3);
  flagged.push_back("wrong_right");
  EXPECT_EQ(error_of(pattern_file(panels, json::array({flagged}))),
            "t.json: key pattern.stitches[0][2]: expected \"right_wrong\", got \"wrong_right\" (string)");
}

TEST(PatternReader, RefusesSelfIntersectingOutlines) {
  // A bow tie: the edges 1 -> 2 and 3 -> 0 cross at (0.5, 0.5).
  json bow = square_panel();
  bow["vertices"] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  EXPECT_EQ(error_of(pattern_file({{"bow", bow}})),
            "t.json: panel 'bow': outline crosses itself: edge 1 meets edge 3 near (0.5, 0.5) m");
  // A curve bulging through the opposite edge: the bottom edge's control point 3 edge
  // lengths to its left reaches y = 1.5 and crosses the top edge at y = 1.
  json bulge = square_panel();
  bulge["edges"][0]["curvature"] = {0.5, 3};
  const std::string message = error_of(pattern_file({{"bulge", bulge}}));
  EXPECT_EQ(message.substr(0, 64), "t.json: panel 'bulge': outline crosses itself: edge 0 meets edge");
  EXPECT_NE(message.find("edge 2 near ("), std::string::npos) << message;
}

TEST(PatternReader, RefusesBadCurvature) {
  json panel = square_panel();
  panel["edges"][3]["curvature"] = {0.5};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 3: curvature: expected [x, y] (two numbers), got [0.5] (array)");
  panel["edges"][3]["curvature"] = {{"type", "spline"}, {"params", {{0.5, 0.1}}}};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 3: curvature: type: unknown curve type \"spline\" (expected quadratic, cubic "
            "or circle)");
  panel["edges"][3]["curvature"] = {{"type", "cubic"}, {"params", {{0.5, 0.1}}}};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 3: curvature: params: expected [[x, y], [x, y]] for a cubic curve, got "
            "[[0.5,0.1]] (array)");
  panel["edges"][3]["curvature"] = {{"type", "circle"}, {"params", {0.4, 0, 1}}};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 3: curvature: params: radius 0.4 is shorter than half the distance between "
            "the edge's endpoints (0.5)");
  panel["edges"][3]["curvature"] = {{"type", "circle"}, {"params", {0.6, 2, 1}}};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 3: curvature: params: large_arc: expected true, false, 1 or 0, got 2 (number)");
}

TEST(PatternReader, RefusesOpenLoopsAndMissingUnits) {
  json panel = square_panel();
  panel["edges"][2]["endpoints"] = {3, 2};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 2: starts at vertex 3 but edge 1 ends at vertex 2 (the edges must form a "
            "closed loop in order)");
  panel = square_panel();
  panel["edges"][1]["endpoints"] = {1, 9};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 1: endpoints: expected [start, end], two vertex indices in [0, 3], got [1,9] "
            "(array)");
  json file = pattern_file({{"front", square_panel()}});
  file["properties"].erase("units_in_meter");
  EXPECT_EQ(error_of(file), "t.json: key properties.units_in_meter: missing");
}

TEST(PatternReader, RefusesGeometryBeyondAHundredMetres) {
  json panel = square_panel();
  panel["vertices"][2] = {150, 1};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': vertex 2: the point (150.0, 1.0) m lies farther than 100.0 m from the panel's origin");
  panel = square_panel();
  panel["edges"][0]["curvature"] = {0.5, 500};
  EXPECT_EQ(error_of(pattern_file({{"front", panel}})),
            "t.json: panel 'front': edge 0: curvature: control point (0.5, 500.0) m lies farther than 100.0 m from the "
            "panel's origin");
}

}  // namespace
}  // namespace weft
