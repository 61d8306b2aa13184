// A node held against two surfaces at once (NodeContact::normal2, docs/collisions.md): its
// displacement along both normals is prescribed and it moves freely only along their crease;
// a second surface whose constraint would pull is let go while the first still holds.
#include <gtest/gtest.h>

#include <vector>

#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::SpringSystem;

namespace {

// Holds node 0 against the floor y = 0 (normal +y) and the wall x = 0 (normal +x), both still.
class Corner : public ContactHandler {
 public:
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>& out) override {
    NodeContact c;
    c.node = 0;
    c.normal = Vec3::UnitY();
    c.normal2 = Vec3::UnitX();
    out.push_back(c);
  }
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX&, VecX&, double, double, ContactReport&) override {}
};

struct NodeEnd {
  Vec3 x, v;
};

// One free 1 kg node at the corner, under `gravity`, 20 steps of 10 ms of `method`.
NodeEnd in_the_corner(const Vec3& gravity, Method method, double alpha) {
  SpringSystem sys(VecX::Constant(1, 1.0), {}, gravity);
  IntegratorSettings settings;
  settings.method = method;
  settings.alpha = alpha;
  settings.dt = 0.01;
  settings.cg_tolerance = 1e-12;
  Integrator in(sys, settings);
  Corner corner;
  in.add_contact_handler(&corner);
  State s;
  s.x = VecX::Zero(3);
  s.v = VecX::Zero(3);
  StepStatistics stats;
  for (int k = 0; k < 20; ++k) in.step(s, settings.dt, stats);
  return {Vec3(s.x.head<3>()), Vec3(s.v.head<3>())};
}

const std::vector<std::pair<Method, double>> kMethods = {
    {Method::kAlphaFamily, 0.5}, {Method::kAlphaFamily, 1.0}, {Method::kBdf2, 1.0}};

}  // namespace

TEST(TwoSurfaces, ANodePressedIntoBothMovesOnlyAlongTheirCrease) {
  // Gravity presses the node into the floor and the wall and pulls it along z: it stays on
  // both (no displacement along either normal, no velocity either) and slides along z as a
  // free node would (frictionless contacts: v_z = g_z t after 0.2 s).
  for (const auto& [method, alpha] : kMethods) {
    SCOPED_TRACE(alpha);
    const NodeEnd r = in_the_corner(Vec3(-3, -9.81, 2), method, alpha);
    EXPECT_NEAR(r.x.x(), 0, 1e-12);
    EXPECT_NEAR(r.x.y(), 0, 1e-12);
    EXPECT_NEAR(r.v.x(), 0, 1e-12);
    EXPECT_NEAR(r.v.y(), 0, 1e-12);
    EXPECT_NEAR(r.v.z(), 2 * 0.2, 1e-9);
    EXPECT_GT(r.x.z(), 0.03);
  }
}

TEST(TwoSurfaces, ASecondSurfaceThatWouldPullIsLetGoAloneWhileTheFirstHolds) {
  // Gravity pulls the node away from the wall and into the floor: it leaves the wall as a free
  // node (v_x = g_x t) and stays on the floor.
  for (const auto& [method, alpha] : kMethods) {
    SCOPED_TRACE(alpha);
    const NodeEnd r = in_the_corner(Vec3(3, -9.81, 0), method, alpha);
    EXPECT_NEAR(r.x.y(), 0, 1e-12);
    EXPECT_NEAR(r.v.y(), 0, 1e-12);
    EXPECT_NEAR(r.v.x(), 3 * 0.2, 1e-9);
    EXPECT_GT(r.x.x(), 0.05);
  }
}
