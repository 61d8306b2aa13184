// Contacts as bounds in one bounded solve (ContactSolve::kBounds, docs/collisions.md,
// "Contacts as bounds") against the active set's filters: the same resting contact at the
// thickness, Coulomb's sticking and sliding, no energy from frictionless contact with a still
// sphere, and fewer solves a step where the active set solves again.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>

#include "sim/simulation_core.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

constexpr double kLayer = 0.003;  // the colliders' thickness

const char* name(ContactSolve solve) { return solve == ContactSolve::kBounds ? "bounds" : "active set"; }

// An n x n square of side `side`, horizontal, centred over the origin at height y, of a linear
// material, stepped by `method` at 2 ms.
Scene square(double side, int n, double y, ContactSolve solve, const char* method = "implicit-midpoint") {
  Scene s;
  s.cloth.grid = GridSpec{side, side, n, n};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.translation = Vec3(-side / 2, y, side / 2);
  for (StressCurve* curve : {&s.cloth.material.weft, &s.cloth.material.warp, &s.cloth.material.shear})
    *curve = StressCurve::linear(curve == &s.cloth.material.shear ? 20 : 200);
  s.cloth.self_collision = false;
  set_method(s, method, std::nullopt, "test");
  s.integrator.dt = 0.002;
  s.integrator.cg_tolerance = 1e-10;
  s.integrator.ssor_single_precision = false;
  s.integrator.contact_solve = solve;
  s.frame_interval = 0.01;
  s.duration = 0.3;
  return s;
}

ColliderSpec collider(ColliderShape shape, double friction) {
  ColliderSpec c;
  c.shape = shape;
  c.thickness = kLayer;
  c.friction = friction;
  if (shape == ColliderShape::kSphere) c.radius = 0.2;
  return c;
}

Vec3 mean_of(const VecX& x) {
  Vec3 sum = Vec3::Zero();
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) sum += node(x, static_cast<int>(i));
  return sum / static_cast<double>(x.size() / 3);
}

TEST(ContactBounds, ClothComesToRestOnAPlaneAtTheThicknessWithNoNormalVelocity) {
  for (const ContactSolve solve : {ContactSolve::kActiveSet, ContactSolve::kBounds})
    for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"}) {
      Scene s = square(0.1, 5, 0.02, solve, method);
      s.duration = 0.5;
      s.colliders.push_back(collider(ColliderShape::kPlane, 0.5));
      Simulation sim(s);
      const RunResult r = run_simulation(sim);
      ASSERT_EQ(r.status, "ok") << name(solve) << ", " << method << ": " << r.message;
      EXPECT_GT(sim.core().statistics().contacts, 0);
      for (int i = 0; i < sim.vertex_count(); ++i) {
        EXPECT_NEAR(sim.positions()[3 * i + 1], kLayer, 1e-9) << name(solve) << ", " << method << ", node " << i;
        EXPECT_NEAR(sim.velocities()[3 * i + 1], 0.0, 1e-9) << name(solve) << ", " << method << ", node " << i;
      }
    }
}

// Tilted gravity: held below the friction angle, sliding with g (sin theta - friction cos theta)
// above it, by either solve.
TEST(ContactBounds, FrictionHoldsBelowTheFrictionAngleAndSlidesWithTheCoulombAccelerationAbove) {
  const double g = 9.81;
  for (const ContactSolve solve : {ContactSolve::kActiveSet, ContactSolve::kBounds})
    for (const auto& [degrees, friction] : {std::pair{20.0, 0.5}, std::pair{30.0, 0.2}, std::pair{45.0, 1.1}}) {
      const double theta = degrees * M_PI / 180;
      Scene s = square(0.1, 5, kLayer, solve);
      s.gravity = Vec3(g * std::sin(theta), -g * std::cos(theta), 0);
      s.colliders.push_back(collider(ColliderShape::kPlane, friction));
      Simulation sim(s);
      const RunResult r = run_simulation(sim);
      const std::string what = std::string(name(solve)) + ", " + std::to_string(degrees) + " degrees";
      ASSERT_EQ(r.status, "ok") << what << ": " << r.message;
      const double a = std::max(0.0, g * (std::sin(theta) - friction * std::cos(theta)));
      const double t = sim.time();
      const Vec3 v = mean_of(sim.velocities());
      if (a == 0) {
        EXPECT_LT(std::abs(v.x()), 1e-9) << what;
      } else {
        EXPECT_NEAR(v.x(), a * t, 1e-6 * a * t) << what;
      }
      EXPECT_NEAR(v.y(), 0.0, 1e-9) << what;
    }
}

// Without friction or damping a still sphere only takes energy out, and every node ends each
// frame outside it.
TEST(ContactBounds, FrictionlessContactWithAStillSphereAddsNoEnergyAndLeavesNoNodeInside) {
  Scene s = square(0.3, 9, 0.25, ContactSolve::kBounds);
  s.colliders.push_back(collider(ColliderShape::kSphere, 0.0));
  s.damping_ratio = 0.0;
  s.cloth.material.viscosity_Ns_m = 0;
  s.integrator.dt = 0.001;
  s.duration = 0.4;
  Simulation sim(s);
  for (int frame = 1; frame <= 40; ++frame) {
    sim.advance_to(0.01 * frame);
    for (int i = 0; i < sim.vertex_count(); ++i)
      ASSERT_GE(node(sim.positions(), i).norm() - 0.2, 0.5 * kLayer) << "node " << i << " at " << sim.time() << " s";
  }
  ASSERT_GT(sim.core().statistics().contacts, 0);
  EXPECT_EQ(sim.core().statistics().fail_safe_moves, 0);
  Simulation whole(s);
  const RunResult r = run_simulation(whole);
  ASSERT_EQ(r.status, "ok") << r.message;
  const double scale = whole.energy_scale();
  for (const EnergyRow& e : r.energy) {
    EXPECT_LE(e.total(), 1e-6 * scale) << "t = " << e.time;
    EXPECT_LE(e.contact_work, 1e-6 * scale) << "t = " << e.time;
  }
}

// A cloth sliding over a sphere with friction: the active set solves a step again wherever a
// stuck contact's impulse leaves the friction cone; the bounded solve lets it slide from the
// next step without a second solve.
TEST(ContactBounds, FewerSolvesAStepThanTheActiveSetWhereStuckContactsSlip) {
  double solves[2];
  for (const ContactSolve solve : {ContactSolve::kActiveSet, ContactSolve::kBounds}) {
    Scene s = square(0.5, 13, 0.21, solve);
    s.colliders.push_back(collider(ColliderShape::kSphere, 0.4));
    s.duration = 0.3;
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    ASSERT_EQ(r.status, "ok") << name(solve) << ": " << r.message;
    const StepStatistics& st = sim.core().statistics();
    ASSERT_GT(st.contacts, 0);
    solves[solve == ContactSolve::kBounds] = static_cast<double>(st.cg_solves) / st.steps;
  }
  EXPECT_LT(solves[1], solves[0]) << "active set " << solves[0] << ", bounds " << solves[1] << " solves a step";
}

}  // namespace
