// The contact handlers' limits where they act (docs/collisions.md): the cloth's repulsion
// impulses take Coulomb's share of the sliding away (friction times the normal change, never
// more, never reversing the slide), at the cloth's own coefficient; and the colliders' end-of-
// step detection holds every node that ends within the whole thickness of a surface.
#include <gtest/gtest.h>

#include <cmath>

#include "collision/colliders.hpp"
#include "collision/self_contact.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

constexpr double kThickness = 0.003;

// A large pinned triangle in the plane y = 0 and one free vertex `gap` above its middle, the
// other two vertices of the free vertex's triangle pinned 5 cm up (out of every pair's reach):
// one vertex-face pair, the free vertex against the face.
struct VertexOverFace {
  std::vector<std::array<int, 3>> triangles = {{0, 1, 2}, {3, 4, 5}};
  VecX x0 = VecX::Zero(18);
  VecX mass = VecX::Constant(6, 1e-3);
  std::vector<char> fixed = {1, 1, 1, 0, 1, 1};
  explicit VertexOverFace(double gap) {
    node(x0, 0) = Vec3(-0.1, 0, -0.1);
    node(x0, 1) = Vec3(0.1, 0, -0.1);
    node(x0, 2) = Vec3(0, 0, 0.1);
    node(x0, 3) = Vec3(0, gap, 0);
    node(x0, 4) = Vec3(0.01, 0.05, 0);
    node(x0, 5) = Vec3(0, 0.05, 0.01);
  }
};

}  // namespace

TEST(SelfContactFriction, ARepulsionTakesFrictionTimesItsNormalChangeOffTheSlideAtTwoCoefficients) {
  // The free vertex 2 mm above the face (thickness 3 mm), approaching at 0.1 m/s and sliding
  // along x at `slide`: the repulsion changes its normal velocity by some dvn > 0 and, by
  // Coulomb's law, its sliding speed by mu dvn where that is less than the slide, and stops
  // the slide (never reverses it) where it is more.
  const double dt = 0.005, approach = 0.1;
  for (double mu : {0.2, 0.5}) {
    for (double slide : {0.1, 0.001}) {
      SCOPED_TRACE(testing::Message() << "friction " << mu << ", slide " << slide);
      VertexOverFace f(0.002);
      SelfContacts self(f.triangles, f.x0, f.mass, f.fixed, kThickness, mu);
      VecX v = VecX::Zero(18);
      node(v, 3) = Vec3(slide, -approach, 0);
      const Vec3 v0 = node(v, 3);
      VecX x1 = f.x0 + dt * v;
      ContactReport report;
      self.finish_step(f.x0, x1, v, 0, dt, report);
      ASSERT_GT(self.statistics().repulsions, 0);
      const Vec3 v1 = node(v, 3);
      const double dvn = v1.y() - v0.y();
      ASSERT_GT(dvn, approach) << "the approach is stopped";
      EXPECT_EQ(v1.z(), 0.0) << "no sideways push";
      if (mu * dvn < slide) {
        EXPECT_NEAR(slide - v1.x(), mu * dvn, 1e-12 * slide) << "Coulomb's share of the normal change";
      } else {
        EXPECT_NEAR(v1.x(), 0.0, 1e-15) << "the slide stopped, not reversed";
      }
      for (int i : {0, 1, 2, 4, 5}) EXPECT_EQ(node(v, i), Vec3::Zero()) << "pinned nodes do not move";
    }
  }
}

TEST(ColliderContactsAtTheEnd, ANodeEndingWithinTheWholeThicknessIsHeldAndOneBeyondItIsNot) {
  // Three nodes of one triangle high above a floor (thickness 4 mm) whose solve ends them at a
  // quarter, three quarters and one and a quarter of the thickness above it: detect_end holds
  // the first two (each where the thickness puts it) and leaves the third alone. Likewise
  // against a sphere.
  const double thickness = 0.004, dt = 0.005;
  ColliderSpec floor;
  floor.shape = ColliderShape::kPlane;
  floor.thickness = thickness;
  floor.friction = 0.4;
  ColliderSpec ball;
  ball.shape = ColliderShape::kSphere;
  ball.radius = 0.5;
  ball.centre = Vec3(0, -0.5, 0);  // its top at the origin, its normal there +y
  ball.thickness = thickness;
  for (const ColliderSpec& spec : {floor, ball}) {
    SCOPED_TRACE(spec.shape == ColliderShape::kPlane ? "plane" : "sphere");
    auto c = make_analytic_collider(spec);
    const double ends[3] = {0.25, 0.75, 1.25};
    VecX x0(9), x1(9);
    for (int k = 0; k < 3; ++k) {
      const double side = 0.001 * (k - 1);  // near the sphere's top
      node(x0, k) = Vec3(side, 0.05, 0.001 * k);
      node(x1, k) = Vec3(side, ends[k] * thickness, 0.001 * k);
    }
    const VecX mass = VecX::Constant(3, 1e-3);
    const std::vector<char> fixed(3, 0), held(3, 0);
    ColliderContacts contacts({c.get()}, mass, fixed, {{0, 1, 2}});
    // The step's detection at its start (here at rest, far from the surface: nothing held),
    // then the solve's end as given.
    std::vector<NodeContact> start;
    contacts.detect(x0, VecX::Zero(9), 0.0, dt, start);
    EXPECT_TRUE(start.empty());
    std::vector<NodeContact> end;
    contacts.detect_end(x0, x1, 0.0, dt, held, end);
    ASSERT_EQ(end.size(), 2u);
    for (const NodeContact& k : end) {
      SCOPED_TRACE(k.node);
      EXPECT_LT(k.node, 2) << "the node ending beyond the thickness is not held";
      EXPECT_LT((k.normal - Vec3::UnitY()).norm(), 0.01);
      // Held so as to end the step at the thickness: its displacement along the normal is the
      // solve's plus what the solve left missing of the thickness (the sphere's surface curves
      // away from the nodes by at most 5 um).
      EXPECT_NEAR(k.normal_displacement,
                  k.normal.dot(node(x1, k.node) - node(x0, k.node)) + (1 - ends[k.node]) * thickness, 1e-5);
      EXPECT_DOUBLE_EQ(k.friction, spec.friction);
      EXPECT_FALSE(k.penetrating);
    }
  }
}
