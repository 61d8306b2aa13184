// A cloth face resting over a ridge of a mesh collider (the collider's vertex between the face's
// vertices, none of them near enough to be held itself) is held in the solve: its vertices get
// contacts along the ridge vertex's normal that put the face at the thickness above it.
#include <gtest/gtest.h>

#include <cmath>

#include "collision/colliders.hpp"

using namespace weft;

namespace {

// A low square pyramid, apex at the origin pointing up (+y), base 2 cm below: closed and wound
// outwards.
std::unique_ptr<Collider> pyramid(double thickness) {
  Points p(5, 3);
  p << 0, 0, 0, -0.1, -0.02, -0.1, 0.1, -0.02, -0.1, 0.1, -0.02, 0.1, -0.1, -0.02, 0.1;
  Triangles t(6, 3);
  t << 0, 2, 1, 0, 3, 2, 0, 4, 3, 0, 1, 4, 1, 2, 3, 1, 3, 4;
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  spec.thickness = thickness;
  spec.friction = 0.4;
  return make_mesh_collider(spec, t, [p](double, Points& out) { out = p; }, true);
}

// One horizontal cloth triangle at height h over the apex, its vertices 7 cm out to the sides
// (1.7 cm above the slopes, beyond the thickness), moving up at `rise` m/s.
struct OneFace {
  VecX x = VecX::Zero(9), v = VecX::Zero(9), mass = VecX::Constant(3, 1e-3);
  std::vector<char> fixed = std::vector<char>(3, 0);
  OneFace(double h, double rise) {
    const double r = 0.07;
    for (int k = 0; k < 3; ++k) {
      const double a = 2 * M_PI * k / 3;
      x.segment<3>(3 * k) = Vec3(r * std::cos(a), h, -r * std::sin(a));
      v.segment<3>(3 * k) = Vec3(0, rise, 0);
    }
  }
};

}  // namespace

TEST(FaceHolds, AFaceSaggingOverAColliderVertexHoldsItsVerticesAlongTheVertexNormal) {
  const double thickness = 0.004, h = 0.6 * thickness, dt = 0.005;
  auto c = pyramid(thickness);
  OneFace cloth(h, 0.0);
  ColliderContacts contacts({c.get()}, cloth.mass, cloth.fixed, {{0, 1, 2}});
  std::vector<NodeContact> out;
  contacts.detect(cloth.x, cloth.v, 0.0, dt, out);
  ASSERT_EQ(out.size(), 3u);
  for (const NodeContact& k : out) {
    EXPECT_LT((k.normal - Vec3::UnitY()).norm(), 1e-9);  // the apex's normal, by symmetry
    // The face's point over the apex ends at the thickness: every vertex rises by the gap.
    EXPECT_NEAR(k.normal_displacement, thickness - h, 1e-12);
    EXPECT_LT(k.surface_velocity.norm(), 1e-12);  // a static collider
    EXPECT_DOUBLE_EQ(k.friction, 0.4);
    EXPECT_FALSE(k.kinematic);
  }
  // The held vertices count as touching the collider (self-contact treats them as immovable).
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(contacts.touching()[i]);
}

TEST(FaceHolds, AFaceRisingClearOfTheVertexOrFarAboveItIsNotHeld) {
  const double thickness = 0.004, dt = 0.005;
  auto c = pyramid(thickness);
  std::vector<NodeContact> out;
  // At 0.6 of the thickness but rising 3 mm in the step: it would end beyond 1.1 thickness.
  OneFace rising(0.6 * thickness, 0.6);
  ColliderContacts a({c.get()}, rising.mass, rising.fixed, {{0, 1, 2}});
  a.detect(rising.x, rising.v, 0.0, dt, out);
  EXPECT_TRUE(out.empty());
  // At rest twice the thickness above the apex.
  OneFace high(2 * thickness, 0.0);
  ColliderContacts b({c.get()}, high.mass, high.fixed, {{0, 1, 2}});
  b.detect(high.x, high.v, 0.0, dt, out);
  EXPECT_TRUE(out.empty());
}

TEST(FaceHolds, APinnedVertexOfTheFaceGetsNoContact) {
  const double thickness = 0.004, dt = 0.005;
  auto c = pyramid(thickness);
  OneFace cloth(0.5 * thickness, 0.0);
  cloth.fixed[1] = 1;
  ColliderContacts contacts({c.get()}, cloth.mass, cloth.fixed, {{0, 1, 2}});
  std::vector<NodeContact> out;
  contacts.detect(cloth.x, cloth.v, 0.0, dt, out);
  ASSERT_EQ(out.size(), 2u);
  for (const NodeContact& k : out) EXPECT_NE(k.node, 1);
}
