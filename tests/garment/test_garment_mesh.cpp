// Garment meshing: every shipped pattern meshes with its outlines kept, areas adding up,
// stitch sides matched vertex for vertex at the sampled stitch points, and the mesher's angle
// bound; the stitch direction rule on a hand-made pattern; refusals name the file and panel.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/garment/garment_mesh.hpp"
#include "garment/sample_patterns.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

constexpr double kTarget_m = 0.015;
constexpr double kMinAngle_deg = 25;

double triangle_area(const std::vector<Vec2>& v, const std::array<int, 3>& t) {
  const Vec2 ab = v[static_cast<size_t>(t[1])] - v[static_cast<size_t>(t[0])];
  const Vec2 ac = v[static_cast<size_t>(t[2])] - v[static_cast<size_t>(t[0])];
  return 0.5 * (ab.x() * ac.y() - ab.y() * ac.x());
}

/// Angle at p between the directions to q and r, in degrees: counter-clockwise from q to r
/// (0 to 360), so at a vertex of a counter-clockwise polygon with q the next point and r the
/// previous one it is the interior angle.
double angle_deg(const Vec2& p, const Vec2& q, const Vec2& r) {
  const Vec2 a = q - p, b = r - p;
  double angle = std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)) * 180 / M_PI;
  return angle < 0 ? angle + 360 : angle;
}

TEST(GarmentMesh, EveryShippedPatternMeshesWithItsOutlinesKept) {
  const auto files = test::sample_pattern_files();
  ASSERT_FALSE(files.empty());
  for (const std::string& file : files) {
    SCOPED_TRACE(file);
    const Pattern pattern = load_pattern(file);
    const GarmentMesh mesh = mesh_garment(pattern);
    ASSERT_EQ(mesh.panels.size(), pattern.panels.size());
    EXPECT_EQ(mesh.segment_counts, edge_segment_counts(pattern, kTarget_m));
    const std::vector<SampledOutline> outlines = pattern_outlines(pattern, mesh.segment_counts);
    for (size_t p = 0; p < mesh.panels.size(); ++p) {
      const GarmentPanelMesh& panel = mesh.panels[p];
      const SampledOutline& outline = outlines[p];
      SCOPED_TRACE(panel.name);
      EXPECT_EQ(panel.name, pattern.panels[p].name);
      ASSERT_EQ(panel.boundary_vertices, static_cast<int>(outline.points_m.size()));
      for (size_t v = 0; v < outline.points_m.size(); ++v)
        ASSERT_EQ(panel.vertices_m[v], outline.points_m[v]);

      // The triangles cover the outline: they are counter-clockwise and their areas add up.
      double area = 0;
      for (const auto& t : panel.triangles) {
        const double a = triangle_area(panel.vertices_m, t);
        ASSERT_GT(a, 0);
        area += a;
      }
      const double outline_area = polygon_area_m2(outline.points_m);
      EXPECT_NEAR(area, outline_area, 1e-9 * outline_area);
      EXPECT_NEAR(panel_mesh_stats(panel).area_m2, outline_area, 1e-9 * outline_area);

      // Each edge's vertices are its own samples, from its start to its end.
      ASSERT_EQ(panel.edge_vertices.size(), pattern.panels[p].edges.size());
      for (size_t e = 0; e < panel.edge_vertices.size(); ++e) {
        const std::vector<Vec2> samples =
            sample_curve(pattern.panels[p].edges[e].curve, mesh.segment_counts[p][e]);
        ASSERT_EQ(panel.edge_vertices[e].size(), samples.size());
        for (size_t k = 0; k < samples.size(); ++k)
          EXPECT_EQ(panel.vertices_m[static_cast<size_t>(panel.edge_vertices[e][k])], samples[k])
              << "edge " << e;
      }
    }
  }
}

TEST(GarmentMesh, StitchSidesAreMatchedAtTheSampledStitchPoints) {
  for (const std::string& file : test::sample_pattern_files()) {
    SCOPED_TRACE(file);
    const Pattern pattern = load_pattern(file);
    const GarmentMesh mesh = mesh_garment(pattern);
    ASSERT_EQ(mesh.stitches.size(), pattern.stitches.size());
    for (size_t s = 0; s < mesh.stitches.size(); ++s) {
      SCOPED_TRACE("stitch " + std::to_string(s));
      const Stitch& stitch = pattern.stitches[s];
      const StitchVertexPairs& st = mesh.stitches[s];
      EXPECT_EQ(st.panel_a, stitch.a.panel);
      EXPECT_EQ(st.edge_a, stitch.a.edge);
      EXPECT_EQ(st.panel_b, stitch.b.panel);
      EXPECT_EQ(st.edge_b, stitch.b.edge);
      const auto& a = mesh.panels[static_cast<size_t>(st.panel_a)];
      const auto& b = mesh.panels[static_cast<size_t>(st.panel_b)];
      EXPECT_EQ(a.edge_vertices[static_cast<size_t>(st.edge_a)].size(),
                b.edge_vertices[static_cast<size_t>(st.edge_b)].size());
      const StitchPoints points = sample_stitch(pattern, stitch, mesh.segment_counts);
      ASSERT_EQ(st.pairs.size(), points.a.size());
      for (size_t k = 0; k < st.pairs.size(); ++k) {
        // Matched vertices are outline points of the two edges, at the stitch's points.
        EXPECT_LT(st.pairs[k][0], a.boundary_vertices);
        EXPECT_LT(st.pairs[k][1], b.boundary_vertices);
        EXPECT_EQ(a.vertices_m[static_cast<size_t>(st.pairs[k][0])], points.a[k]) << "pair " << k;
        EXPECT_EQ(b.vertices_m[static_cast<size_t>(st.pairs[k][1])], points.b[k]) << "pair " << k;
      }
    }
  }
}

// The mesher's quality statement (src/mesh/panel_mesher.hpp) covers outlines sampled at 0.6 to
// 1.3 target edges: every triangle has its smallest angle at least min_angle_deg, except where
// that angle sits at an outline corner sharper than 60 degrees, or the triangle joins outline
// points only (a panel too narrow for an interior point, next to such a corner). Edges shorter
// than 0.6 targets are sampled as they are (one segment), outside that statement: a triangle
// standing on such a segment can have its small angle opposite it (the GarmentCode jumpsuit
// has edges of 0.9 to 1.8 mm at the waist).
TEST(GarmentMesh, SmallestAnglesMeetTheMeshersBound) {
  for (const std::string& file : test::sample_pattern_files()) {
    SCOPED_TRACE(file);
    const GarmentMesh mesh = mesh_garment(load_pattern(file));
    for (const GarmentPanelMesh& panel : mesh.panels) {
      SCOPED_TRACE(panel.name);
      const auto& v = panel.vertices_m;
      const int n = panel.boundary_vertices;
      auto interior_angle = [&](int i) {
        return angle_deg(v[static_cast<size_t>(i)], v[static_cast<size_t>((i + 1) % n)],
                         v[static_cast<size_t>((i + n - 1) % n)]);
      };
      int excepted = 0;
      for (const auto& t : panel.triangles) {
        for (int c = 0; c < 3; ++c) {
          const int i = t[static_cast<size_t>(c)];
          const double angle =
              angle_deg(v[static_cast<size_t>(i)],
                        v[static_cast<size_t>(t[static_cast<size_t>((c + 1) % 3)])],
                        v[static_cast<size_t>(t[static_cast<size_t>((c + 2) % 3)])]);
          if (angle >= kMinAngle_deg - 1e-9) continue;
          const bool sharp_corner = i < n && interior_angle(i) < 60;
          const bool outline_only = t[0] < n && t[1] < n && t[2] < n;
          const int j = t[static_cast<size_t>((c + 1) % 3)],
                    k = t[static_cast<size_t>((c + 2) % 3)];
          const bool opposite_outline_segment =
              j < n && k < n && (k == (j + 1) % n || j == (k + 1) % n);
          const bool opposite_short_segment =
              opposite_outline_segment &&
              (v[static_cast<size_t>(j)] - v[static_cast<size_t>(k)]).norm() < 0.6 * kTarget_m;
          EXPECT_TRUE(sharp_corner || outline_only || opposite_short_segment)
              << "angle " << angle << " deg at vertex " << i;
          ++excepted;
        }
      }
      // The exceptions are the few triangles at sharp corners, not a fraction of the mesh.
      EXPECT_LE(excepted, 2 + static_cast<int>(panel.triangles.size()) / 100);
    }
  }
}

// Two unit squares: "a" counter-clockwise, "b" clockwise (its outline runs backwards). Edge 1 of
// a runs (1, 0) -> (1, 1); edge 0 of b runs (0, 0) -> (0, 1).
Pattern two_squares(bool same_direction) {
  const std::string stitch =
      same_direction ? R"([{"panel": "a", "edge": 1}, {"panel": "b", "edge": 0}, "right_wrong"])"
                     : R"([{"panel": "a", "edge": 1}, {"panel": "b", "edge": 0}])";
  return parse_pattern(R"({"properties": {"units_in_meter": 1},
    "pattern": {"panels": {
      "a": {"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]],
            "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]},
      "b": {"vertices": [[0, 0], [0, 1], [1, 1], [1, 0]],
            "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]}},
    "stitches": [)" + stitch +
                           "]}}",
                       "squares.json");
}

TEST(GarmentMesh, StitchDirectionFlagDecidesWhichEndsMeet) {
  for (const bool same : {false, true}) {
    SCOPED_TRACE(same ? "right_wrong" : "right to right");
    GarmentMeshOptions options;
    options.target_edge_m = 0.1;
    const Pattern pattern = two_squares(same);
    ASSERT_TRUE(pattern.panels[1].clockwise);
    const GarmentMesh mesh = mesh_garment(pattern, options);
    const auto& pairs = mesh.stitches.at(0).pairs;
    ASSERT_EQ(pairs.size(), 11u);
    const auto& a = mesh.panels[0].vertices_m;
    const auto& b = mesh.panels[1].vertices_m;
    for (size_t k = 0; k < pairs.size(); ++k) {
      const double s = 0.1 * static_cast<double>(k);
      // Side a from its start (1, 0) up; side b from its end (0, 1) down, or from its start.
      EXPECT_NEAR((a[static_cast<size_t>(pairs[k][0])] - Vec2(1, s)).norm(), 0, 1e-12) << k;
      EXPECT_NEAR((b[static_cast<size_t>(pairs[k][1])] - Vec2(0, same ? s : 1 - s)).norm(), 0,
                  1e-12)
          << k;
    }
  }
}

TEST(GarmentMesh, MaterialDirectionsFollowTheGrainAngle) {
  GarmentPanelMesh panel;
  panel.vertices_m = {Vec2(0.3, 0.5)};
  EXPECT_EQ(warp_direction(panel), Vec2(0, 1));
  EXPECT_EQ(weft_direction(panel), Vec2(1, 0));
  EXPECT_EQ(material_coordinates(panel)[0], Vec2(0.3, 0.5));
  panel.grain_angle_rad = M_PI / 2;  // warp along -x, weft along +y
  EXPECT_NEAR((warp_direction(panel) - Vec2(-1, 0)).norm(), 0, 1e-15);
  EXPECT_NEAR((weft_direction(panel) - Vec2(0, 1)).norm(), 0, 1e-15);
  EXPECT_NEAR((material_coordinates(panel)[0] - Vec2(0.5, -0.3)).norm(), 0, 1e-15);
}

TEST(GarmentMesh, FlatLayoutKeepsPanelsApart) {
  for (const std::string& file : test::sample_pattern_files()) {
    SCOPED_TRACE(file);
    const GarmentMesh mesh = mesh_garment(load_pattern(file));
    const double gap_m = 0.05;
    const std::vector<Vec2> offsets = flat_layout_offsets(mesh, gap_m);
    std::vector<Vec2> lo, hi;
    for (size_t p = 0; p < mesh.panels.size(); ++p) {
      lo.push_back(Vec2::Constant(INFINITY));
      hi.push_back(Vec2::Constant(-INFINITY));
      for (const Vec2& x : mesh.panels[p].vertices_m) {
        lo[p] = lo[p].cwiseMin(x + offsets[p]);
        hi[p] = hi[p].cwiseMax(x + offsets[p]);
      }
      EXPECT_GE(lo[p].minCoeff(), -1e-12);
    }
    // Bounding boxes are at least the gap apart along x or along y.
    for (size_t p = 0; p < lo.size(); ++p)
      for (size_t q = p + 1; q < lo.size(); ++q) {
        const bool apart_x =
            lo[q].x() - hi[p].x() >= gap_m - 1e-9 || lo[p].x() - hi[q].x() >= gap_m - 1e-9;
        const bool apart_y =
            lo[q].y() - hi[p].y() >= gap_m - 1e-9 || lo[p].y() - hi[q].y() >= gap_m - 1e-9;
        EXPECT_TRUE(apart_x || apart_y) << mesh.panels[p].name << " and " << mesh.panels[q].name;
      }
  }
}

TEST(GarmentMesh, ABadEdgeLengthIsRefusedNamingTheFile) {
  GarmentMeshOptions options;
  options.target_edge_m = 0;
  try {
    mesh_garment(two_squares(false), options);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "squares.json: mesh edge length 0 m: expected a positive length");
  }
}

// A crescent: the bottom edge bulges down to y = -0.8 and the top edge dips to y = -0.3 above
// it, a simple outline. Sampled at 2 m the bottom gets one segment (its chord y = 0) and the
// top two, whose middle point (near y = -0.3) lies below that chord: the sampled outline
// crosses itself, and the mesher's refusal comes back naming the file and the panel.
TEST(GarmentMesh, APanelThatCannotBeMeshedIsNamed) {
  const Pattern pattern =
      parse_pattern(R"({"properties": {"units_in_meter": 1, "curvature_coords": "absolute"},
    "pattern": {"panels": {"crescent": {"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]],
      "edges": [{"endpoints": [0, 1], "curvature": [0.5, -1.6]}, {"endpoints": [1, 2]},
                {"endpoints": [2, 3], "curvature": [0.5, -1.6]}, {"endpoints": [3, 0]}]}}}})",
                    "crescent.json");
  GarmentMeshOptions options;
  options.target_edge_m = 2;
  ASSERT_EQ(edge_segment_counts(pattern, 2.0)[0][0], 1);
  ASSERT_EQ(edge_segment_counts(pattern, 2.0)[0][2], 2);
  try {
    mesh_garment(pattern, options);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    // The bottom chord (points 0 to 1) is crossed by the top's first segment (points 2 to 3)
    // at y = 0, x = 1 - 0.5 / 1.3.
    EXPECT_EQ(message,
              "crescent.json: panel 'crescent': meshing at 2 m: panel outline: segment from outer "
              "point 0 to "
              "point 1 meets segment from outer point 2 to point 3 at (0.615385, 0); expected a "
              "simple outline "
              "(no crossing or touching segments)");
  }
}

}  // namespace
}  // namespace weft
