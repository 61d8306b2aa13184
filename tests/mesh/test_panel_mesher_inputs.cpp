// mesh_panel (mesh/panel_mesher.hpp) refuses bad outlines and options with an InputError
// that names the ring, the point index and what was expected.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mesh/panel_mesher.hpp"
#include "mesh/test_panel_mesher_shapes.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

std::string refusal(const PanelOutline& outline, const PanelMeshOptions& options = {}) {
  try {
    mesh_panel(outline, options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

const std::vector<Vec2> kUnitSquare{{0, 0}, {1, 0}, {1, 1}, {0, 1}};

TEST(PanelMesherInput, TooFewPoints) {
  EXPECT_EQ(refusal({{{0, 0}, {1, 0}}, {}}),
            "panel outline: the outer boundary has 2 points; expected at least 3");
  EXPECT_EQ(refusal({kUnitSquare, {{{0.5, 0.5}, {0.6, 0.5}}}}),
            "panel outline: hole 0 has 2 points; expected at least 3");
}

TEST(PanelMesherInput, RepeatedAndNonFinitePoints) {
  EXPECT_EQ(
      refusal({{{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}}, {}}),
      "panel outline: outer point 4 repeats outer point 0 at (0, 0); expected distinct points (no "
      "closing point)");
  EXPECT_EQ(refusal({kUnitSquare,
                     {{{0.2, 0.2}, {0.4, 0.2}, {0.3, 0.4}}, {{0.6, 0.6}, {0.8, 0.6}, {0.4, 0.2}}}}),
            "panel outline: hole 1 point 2 repeats hole 0 point 1 at (0.4, 0.2); expected distinct "
            "points (no "
            "closing point)");
  EXPECT_EQ(refusal({{{0, 0}, {1, 0}, {1, std::numeric_limits<double>::quiet_NaN()}}, {}}),
            "panel outline: outer point 2 is not finite: (1, nan)");
}

TEST(PanelMesherInput, SelfIntersectingOutlines) {
  // A bow tie: the segments 0-1 and 2-3 cross at (0.5, 0.5).
  EXPECT_EQ(refusal({{{0, 0}, {1, 1}, {1, 0}, {0, 1}}, {}}),
            "panel outline: segment from outer point 0 to point 1 meets segment from outer point 2 "
            "to point 3 at "
            "(0.5, 0.5); expected a simple outline (no crossing or touching segments)");
  // Point 4 touches segment 1-2 without crossing it.
  EXPECT_EQ(refusal({{{0, 0}, {2, 0}, {2, 2}, {1, 2}, {2, 1}, {0, 2}}, {}}),
            "panel outline: segment from outer point 1 to point 2 meets segment from outer point 3 "
            "to point 4 at "
            "(2, 1); expected a simple outline (no crossing or touching segments)");
  // A hole sticking out of the panel.
  EXPECT_EQ(refusal({kUnitSquare, {{{0.5, 0.5}, {1.5, 0.5}, {0.5, 0.7}}}}),
            "panel outline: segment from outer point 1 to point 2 meets segment from hole 0 point "
            "0 to point 1 at "
            "(1, 0.5); expected a simple outline (no crossing or touching segments)");
  // Three points on a line: the closing segment runs back over the first one.
  EXPECT_EQ(refusal({{{0, 0}, {1, 0}, {2, 0}}, {}}),
            "panel outline: segment from outer point 0 to point 1 meets segment from outer point 2 "
            "to point 0 at "
            "(1, 0); expected a simple outline (no crossing or touching segments)");
}

TEST(PanelMesherInput, HolesOutsideThePanelOrInsideEachOther) {
  EXPECT_EQ(refusal({kUnitSquare, {{{2, 2}, {3, 2}, {2, 3}}}}),
            "panel outline: hole 0 lies outside the outer boundary (its point 0 is at (2, 2))");
  EXPECT_EQ(refusal({kUnitSquare,
                     {{{0.1, 0.1}, {0.9, 0.1}, {0.5, 0.9}}, {{0.4, 0.3}, {0.6, 0.3}, {0.5, 0.5}}}}),
            "panel outline: hole 1 lies inside hole 0");
}

TEST(PanelMesherInput, BadOptions) {
  const PanelOutline square{kUnitSquare, {}};
  PanelMeshOptions options;
  options.target_edge_m = 0;
  EXPECT_EQ(refusal(square, options),
            "panel mesh: target_edge_m = 0; expected a positive length in metres");
  options = {};
  options.min_angle_deg = 40;
  EXPECT_EQ(refusal(square, options),
            "panel mesh: min_angle_deg = 40; expected an angle in (0, 34] degrees");
}

TEST(PanelMesherInput, TooManyVerticesNeeded) {
  // A 1 m square at 1.5 cm needs thousands of vertices: refinement stops at the cap.
  PanelMeshOptions options;
  options.max_vertices = 500;
  EXPECT_EQ(refusal({test::sampled_polygon(kUnitSquare, 0.015), {}}, options),
            "panel mesh: more than max_vertices = 500 vertices needed at target_edge_m = 0.015; "
            "expected a "
            "larger target_edge_m or max_vertices");
}

}  // namespace
}  // namespace weft
