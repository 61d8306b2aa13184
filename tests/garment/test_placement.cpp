// Placement (place_garment) of the shipped patterns: no two vertices that the weld keeps apart
// are placed on one point. The open jacket's two fronts are drawn in its file edge on edge
// along the centre front, with no stitch between them; placed so, their edges lay vertex on
// vertex, sewing could not part them (coincident vertices have no direction to push apart),
// and the written garment held some 300 intersecting triangle pairs there.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <tuple>

#include "sample_patterns.hpp"
#include "placed_lengths.hpp"
#include "weft/garment/placement.hpp"

namespace weft {
namespace {

/// The smallest distance between two vertices of different panels that the weld of every
/// stitch would not merge, and the panels of that pair.
struct Nearest {
  double distance_m = 1e30;
  int panel_a = -1, panel_b = -1;
};

Nearest nearest_unwelded(const PlacedGarment& placed) {
  const int n = placed.mesh.num_vertices();
  std::vector<int> root(n);
  std::iota(root.begin(), root.end(), 0);
  auto find = [&](int i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (const auto& p : placed.seam_pairs) root[find(p[0])] = find(p[1]);
  std::vector<int> panel(n);
  for (size_t p = 0; p + 1 < placed.panel_first_vertex.size(); ++p)
    for (int v = placed.panel_first_vertex[p]; v < placed.panel_first_vertex[p + 1]; ++v) panel[v] = static_cast<int>(p);
  Nearest out;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (panel[a] == panel[b] || find(a) == find(b)) continue;
      const double d = (placed.mesh.positions.row(a) - placed.mesh.positions.row(b)).norm();
      if (d < out.distance_m) out = {d, panel[a], panel[b]};
    }
  return out;
}

TEST(PlacementApart, NoTwoVerticesTheWeldKeepsApartArePlacedTogether) {
  const BindBody body = load_bind_body(BodyColliderSpec{}, 1.0);
  GarmentMeshOptions options;
  options.target_edge_m = 0.05;
  int moved = 0;
  for (const std::string& file : test::sample_pattern_files()) {
    const Pattern pattern = load_pattern(file);
    const PlacedGarment placed = place_garment(pattern, mesh_garment(pattern, options), body);
    const Nearest near = nearest_unwelded(placed);
    // Half the 6 mm the placement leaves between panels that meet edge on edge.
    EXPECT_GT(near.distance_m, 0.003) << pattern.name << ": panels '" << pattern.panels[near.panel_a].name
                                      << "' and '" << pattern.panels[near.panel_b].name << "'";
    if (pattern.name == "jacket") moved = placed.panels_moved_apart;
  }
  EXPECT_GE(moved, 1) << "the jacket's fronts meet edge on edge in its file";
}

// The four-panel skirt flares from 0.76 m round the waist to 1.68 m at the hem. Rolled onto
// one cylinder as wide as its hem, its waist seams stood 25 cm open and sewing crumpled it;
// on a cone (developable, like the cylinder) each panel keeps its lengths and the girth grows
// down the skirt as the panels' summed width does.
TEST(PlacementCone, AFlaredSkirtGoesOnAConeAtTheWaistKeepingItsLengths) {
  const BindBody body = load_bind_body(BodyColliderSpec{}, 1.0);
  const Pattern pattern =
      load_pattern(std::string(WEFT_SOURCE_DIR) + "/data/patterns/garment_pattern_generator/skirt_4_panels.json");
  GarmentMeshOptions options;
  options.target_edge_m = 0.03;
  const PlacedGarment placed = place_garment(pattern, mesh_garment(pattern, options), body);
  // Lengths: every edge as long as in the flat panel, to within 1% (rolling is isometric; a
  // 3 cm chord on a radius above 12 cm is within 0.3% of its arc).
  EXPECT_LT(test::largest_edge_stretch(placed), 0.01);
  // A cone: the vertices' distance from the vertical axis grows down the skirt, and the top
  // sits at the waist, below the armpits.
  const Vec3 centre = placed.mesh.positions.colwise().mean().transpose();
  double top = -1e30, bottom = 1e30;
  for (int v = 0; v < placed.mesh.num_vertices(); ++v) {
    top = std::max(top, placed.mesh.positions(v, 1));
    bottom = std::min(bottom, placed.mesh.positions(v, 1));
  }
  double top_radius = 0, bottom_radius = 0;
  for (int v = 0; v < placed.mesh.num_vertices(); ++v) {
    const double r = std::hypot(placed.mesh.positions(v, 0) - centre.x(), placed.mesh.positions(v, 2) - centre.z());
    if (placed.mesh.positions(v, 1) > top - 0.02) top_radius = std::max(top_radius, r);
    if (placed.mesh.positions(v, 1) < bottom + 0.02) bottom_radius = std::max(bottom_radius, r);
  }
  EXPECT_GT(bottom_radius, 1.5 * top_radius);
  const int arm = body.rig.find("LeftArm");
  ASSERT_GE(arm, 0);
  EXPECT_LT(top, body.rig.head_bind[arm].y() - 0.2);
  // Every panel on the torso, facing out: each triangle's normal away from the axis.
  int inward = 0;
  for (const auto& t : placed.mesh.triangles) {
    const Vec3 a = placed.mesh.positions.row(t[0]), b = placed.mesh.positions.row(t[1]), c = placed.mesh.positions.row(t[2]);
    const Vec3 n = (b - a).cross(c - a), m = (a + b + c) / 3 - centre;
    inward += Vec3(m.x(), 0, m.z()).dot(n) < 0 ? 1 : 0;
  }
  EXPECT_EQ(inward, 0);
  EXPECT_EQ(placed.vertices_pushed_out, 0);
}

// Trousers go on the body with its legs apart: each leg turned kLegsApartDeg out about the
// forward axis at its hip, every joint above the hips where it was.
TEST(PlacementLegsApart, EachLegTurnsOutAboutItsHipAndTheRestStays) {
  const BindBody body = load_bind_body(BodyColliderSpec{}, 1.0);
  ASSERT_EQ(body.legs_apart_positions.rows(), body.positions.rows());
  const Rig& bind = body.rig;
  const Rig& apart = body.legs_apart_rig;
  for (const auto& [hip_name, foot_name, side] :
       {std::tuple{"LeftUpLeg", "LeftFoot", 1.0}, std::tuple{"RightUpLeg", "RightFoot", -1.0}}) {
    const int hip = bind.find(hip_name), foot = bind.find(foot_name);
    ASSERT_GE(hip, 0);
    ASSERT_GE(foot, 0);
    EXPECT_LT((apart.head_bind[hip] - bind.head_bind[hip]).norm(), 1e-12);
    const Vec3 a = bind.head_bind[foot] - bind.head_bind[hip], b = apart.head_bind[foot] - apart.head_bind[hip];
    EXPECT_NEAR(a.norm(), b.norm(), 1e-9);
    // Turned about z (the forward axis): by the angle in the xy plane, z kept, and outwards
    // (towards the leg's own side).
    const double turn = std::atan2(b.y(), b.x()) - std::atan2(a.y(), a.x());
    EXPECT_NEAR(side * turn * 180 / 3.14159265358979323846, kLegsApartDeg, 1e-6);
    EXPECT_NEAR(a.z(), b.z(), 1e-9);
    EXPECT_GT(side * (b.x() - a.x()), 0.05);
  }
  for (const char* bone : {"Hips", "Spine", "Neck", "Head", "LeftArm", "RightHand"}) {
    const int b = bind.find(bone);
    if (b < 0) continue;
    EXPECT_LT((apart.head_bind[b] - bind.head_bind[b]).norm(), 1e-12) << bone;
  }
  // The skin follows: the lowest vertices (the feet) move out, the highest (the head) stay.
  Eigen::Index low = 0, high = 0;
  body.positions.col(1).minCoeff(&low);
  body.positions.col(1).maxCoeff(&high);
  EXPECT_GT(std::abs(body.legs_apart_positions(low, 0)) - std::abs(body.positions(low, 0)), 0.05);
  EXPECT_LT((body.legs_apart_positions.row(high) - body.positions.row(high)).norm(), 1e-12);

  // A jumpsuit is placed on the legs apart; a shirt, which has no legs, is not.
  GarmentMeshOptions options;
  options.target_edge_m = 0.05;
  int seen = 0;
  for (const std::string& file : test::sample_pattern_files()) {
    const Pattern pattern = load_pattern(file);
    if (pattern.name != "js_mean_all" && pattern.name != "shirt_mean") continue;
    ++seen;
    EXPECT_EQ(place_garment(pattern, mesh_garment(pattern, options), body).legs_apart, pattern.name == "js_mean_all");
  }
  EXPECT_EQ(seen, 2);
}

}  // namespace
}  // namespace weft
