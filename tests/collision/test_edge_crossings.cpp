// A cloth edge carried across a ridge of a mesh collider, both its ends staying outside the
// collider and no collider vertex near the cloth's face, is caught by the colliders' fail-safe
// (continuous detection of the cloth's edges against the collider's) and ends over the ridge.
#include <gtest/gtest.h>

#include "collision/colliders.hpp"
#include "collision/geometry.hpp"

using namespace weft;

namespace {

// A closed prism lying along x (from -0.2 to 0.2 m), its cross-section a triangle with the apex
// (the ridge) at y = 0, z = 0 and the base 10 cm below, 20 cm wide: slopes of 45 degrees, wound
// outwards; raised by `rise` m/s from t = 0.
std::unique_ptr<Collider> prism(double thickness, double rise) {
  Points p(6, 3);
  p << -0.2, 0, 0, 0.2, 0, 0, -0.2, -0.1, -0.1, 0.2, -0.1, -0.1, -0.2, -0.1, 0.1, 0.2, -0.1, 0.1;
  Triangles t(8, 3);
  t << 0, 4, 5, 0, 5, 1, 0, 1, 3, 0, 3, 2, 2, 3, 5, 2, 5, 4, 0, 2, 4, 1, 5, 3;
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  spec.thickness = thickness;
  return make_mesh_collider(
      spec, t,
      [p, rise](double time, Points& out) {
        out = p;
        out.col(1).array() += rise * time;
      },
      true);
}

// One cloth triangle: an edge (nodes 0 and 1) across the ridge's line at x = 0, 4 cm long, and a
// third node 30 cm along x, beyond the prism's end, 10 cm up.
struct Cloth {
  VecX x0 = VecX::Zero(9), x1 = VecX::Zero(9), v1 = VecX::Zero(9), mass = VecX::Constant(3, 1e-3);
  std::vector<char> fixed = std::vector<char>(3, 0);
  Cloth(double y_start, double y_end, double dt) {
    x0 << 0, y_start, -0.02, 0, y_start, 0.02, 0.3, 0.1, 0;
    x1 << 0, y_end, -0.02, 0, y_end, 0.02, 0.3, 0.1, 0;
    v1 = (x1 - x0) / dt;
  }
};

// Whether the cloth's triangle meets one of the collider's triangles at the step's end.
bool crosses(const Collider& c, const VecX& x) {
  const Points& p = *c.end_vertices();
  for (const auto& t : *c.triangle_list())
    if (triangles_intersect(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), p.row(t[0]).transpose(),
                            p.row(t[1]).transpose(), p.row(t[2]).transpose()))
      return true;
  return false;
}

// The end's distance of node i from the prism's slopes (outside: positive).
double slope_distance(const VecX& x, int i, double ridge_y) {
  const Vec3 p = x.segment<3>(3 * i);
  return (p.y() - ridge_y + std::abs(p.z())) / std::sqrt(2.0);
}

}  // namespace

TEST(EdgeCrossings, AClothEdgeFallingAcrossARidgeEndsAboveIt) {
  const double thickness = 0.004, dt = 0.005;
  auto c = prism(thickness, 0.0);
  // From 1 cm above the ridge to 8 mm under it: the ends stay more than twice the thickness
  // off the slopes (the vertices' own fail-safe leaves them), but the edge passes through the
  // prism's top and the ridge pierces the cloth's face.
  Cloth cloth(0.01, -0.008, dt);
  c->prepare(0.0, dt);
  ASSERT_TRUE(crosses(*c, cloth.x1));
  for (int i = 0; i < 2; ++i) ASSERT_GT(slope_distance(cloth.x1, i, 0.0), 2 * thickness);
  ColliderContacts contacts({c.get()}, cloth.mass, cloth.fixed, {{0, 1, 2}});
  ContactReport report;
  contacts.finish_step(cloth.x0, cloth.x1, cloth.v1, 0.0, dt, report);
  EXPECT_FALSE(crosses(*c, cloth.x1));
  // The edge met the ridge at its middle, along +y (by symmetry): both ends are lifted by the
  // same amount, the middle to kEdgeLiftHeight thicknesses over the ridge.
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(cloth.x1[3 * i + 1], kEdgeLiftHeight * thickness, 1e-9) << i;
    EXPECT_EQ(cloth.x1[3 * i], 0.0) << i;
    EXPECT_NEAR(cloth.x1[3 * i + 2], i == 0 ? -0.02 : 0.02, 1e-12) << i;
    // No longer moving into the static ridge; the sideways velocity untouched.
    EXPECT_GE(cloth.v1[3 * i + 1], 0.0) << i;
  }
  EXPECT_EQ(cloth.x1.segment<3>(6), Vec3(0.3, 0.1, 0));
  EXPECT_GT(report.fail_safe_moves, 0);
  EXPECT_LT(report.work, 0);  // taking the edge's fall out of it only removes kinetic energy
}

TEST(EdgeCrossings, ARidgeRisingIntoAClothEdgeLiftsItAndGivesItTheRidgesSpeed) {
  const double thickness = 0.004, dt = 0.005, rise = 2.0;
  auto c = prism(thickness, rise);
  // The edge hangs still 5 mm over the ridge, which rises 1 cm in the step.
  Cloth cloth(0.005, 0.005, dt);
  c->prepare(0.0, dt);
  const double ridge_end = rise * dt;
  ASSERT_TRUE(crosses(*c, cloth.x1));
  for (int i = 0; i < 2; ++i) ASSERT_GT(slope_distance(cloth.x1, i, ridge_end), 2 * thickness);
  ColliderContacts contacts({c.get()}, cloth.mass, cloth.fixed, {{0, 1, 2}});
  ContactReport report;
  contacts.finish_step(cloth.x0, cloth.x1, cloth.v1, 0.0, dt, report);
  EXPECT_FALSE(crosses(*c, cloth.x1));
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(cloth.x1[3 * i + 1], ridge_end + kEdgeLiftHeight * thickness, 1e-9) << i;
    EXPECT_NEAR(cloth.v1[3 * i + 1], rise, 1e-9) << i;  // carried up with the ridge, no faster
  }
}

TEST(EdgeCrossings, AClothEdgeSettlingOnOneSlopeIsLeftAlone) {
  const double thickness = 0.004, dt = 0.005;
  auto c = prism(thickness, 0.0);
  // Both ends over the slope on the +z side, 2 to 6 cm from the ridge, falling to 3 mm off it:
  // near the collider, but never near one of its edges.
  VecX x0(9), x1(9), mass = VecX::Constant(3, 1e-3);
  const double s = std::sqrt(2.0);
  x0 << 0, -0.02 + 0.01 * s, 0.02, 0, -0.06 + 0.01 * s, 0.06, 0.05, -0.04 + 0.01 * s, 0.04;
  x1 << 0, -0.02 + 0.003 * s, 0.02, 0, -0.06 + 0.003 * s, 0.06, 0.05, -0.04 + 0.003 * s, 0.04;
  VecX v1 = (x1 - x0) / dt;
  const VecX x1_before = x1, v1_before = v1;
  c->prepare(0.0, dt);
  ColliderContacts contacts({c.get()}, mass, std::vector<char>(3, 0), {{0, 1, 2}});
  ContactReport report;
  contacts.finish_step(x0, x1, v1, 0.0, dt, report);
  EXPECT_EQ(x1, x1_before);
  EXPECT_EQ(v1, v1_before);
  EXPECT_EQ(report.fail_safe_moves, 0);
}

TEST(EdgeCrossings, ALongClothEdgeWhoseEndsStayFarFromTheRidgeIsCaughtCrossingIt) {
  const double thickness = 0.004, dt = 0.005;
  auto c = prism(thickness, 0.0);
  // An edge 6 cm long moving 3 mm down across the ridge: its ends end 2 cm off the slopes,
  // beyond any reach their own queries have (the thickness and their 3 mm of motion), while its
  // middle passes through the ridge.
  VecX x0(9), x1(9), mass = VecX::Constant(3, 1e-3);
  x0 << 0, 0.0015, -0.03, 0, 0.0015, 0.03, 0.3, 0.1, 0;
  x1 << 0, -0.0015, -0.03, 0, -0.0015, 0.03, 0.3, 0.1, 0;
  VecX v1 = (x1 - x0) / dt;
  c->prepare(0.0, dt);
  ASSERT_TRUE(crosses(*c, x1));
  for (int i = 0; i < 2; ++i) ASSERT_GT(slope_distance(x1, i, 0.0), 0.02);
  ColliderContacts contacts({c.get()}, mass, std::vector<char>(3, 0), {{0, 1, 2}});
  ContactReport report;
  contacts.finish_step(x0, x1, v1, 0.0, dt, report);
  EXPECT_FALSE(crosses(*c, x1));
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(x1[3 * i + 1], kEdgeLiftHeight * thickness, 1e-9) << i;
  EXPECT_GT(report.fail_safe_moves, 0);
}
