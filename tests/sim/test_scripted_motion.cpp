// Pins and colliders moved between steps (Simulation::move_pins, move_collider), and the
// storage of the State's positions and velocities, which the Python module's arrays view.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

/// A 0.4 m square held at two corners, horizontal at rest.
Scene sheet(const std::string& method) {
  Scene s;
  s.cloth.grid = GridSpec{0.4, 0.4, 5, 5};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.pin_grid_nodes = {{0, 0}, {-1, 0}};
  set_method(s, method, std::nullopt, "test");
  s.integrator.dt = 0.01;
  s.frame_interval = 0.01;
  s.duration = 0.2;
  return s;
}

}  // namespace

TEST(ScriptedMotion, DegreesFromRotationInvertsRotationFromDegrees) {
  for (const Vec3& deg : {Vec3(0, 0, 0), Vec3(30, -40, 170), Vec3(-120, 89, 5), Vec3(10, 95, -60), Vec3(180, 0, 90)}) {
    const Mat3 R = rotation_from_degrees(deg);
    EXPECT_LT((rotation_from_degrees(degrees_from_rotation(R)) - R).norm(), 1e-12) << deg.transpose();
  }
}

// A pin moves at a constant velocity and stops on its target; the other pin stays put.
// (Without self-collision: its last-resort impact zones may hold a pin still for a step where
// the explicit method shakes the cloth; the pin then catches up, and still arrives on time.)
TEST(ScriptedMotion, MovedPinsArriveOnTheirTargetsAndStop) {
  for (const char* method : {"implicit-midpoint", "bdf2", "rk4", "rk4 with self-collision"}) {
    SCOPED_TRACE(method);
    const bool self = std::string(method).find("self") != std::string::npos;
    Scene scene = sheet(self ? "rk4" : method);
    scene.cloth.self_collision = self;
    Simulation sim(scene);
    std::vector<int> pins;
    for (int i = 0; i < sim.core().model().num_vertices(); ++i)
      if (sim.core().model().pinned[i]) pins.push_back(i);
    ASSERT_EQ(pins.size(), 2u);
    sim.advance_to(0.03);  // BDF-2 has a history by now
    const Vec3 start = node(sim.core().state().x, pins[0]), other = node(sim.core().state().x, pins[1]);
    const Vec3 target = start + Vec3(0.05, 0.02, -0.01);
    sim.move_pins({pins[0]}, {target}, 0.07);  // four steps
    EXPECT_EQ(sim.moving_pins(), 1u);
    sim.advance_to(0.05);
    if (!self) EXPECT_LT((node(sim.core().state().x, pins[0]) - (start + 0.5 * (target - start))).norm(), 1e-12);
    sim.advance_to(0.07);
    EXPECT_EQ(node(sim.core().state().x, pins[0]), target);
    EXPECT_EQ(sim.moving_pins(), 0u);
    sim.advance_to(0.1);
    EXPECT_EQ(node(sim.core().state().x, pins[0]), target);
    EXPECT_EQ(node(sim.core().state().v, pins[0]), Vec3::Zero());
    EXPECT_EQ(node(sim.core().state().x, pins[1]), other);
  }
}

// An arrival between steps is rounded to whole steps: the pin arrives at a step's end.
TEST(ScriptedMotion, PinArrivalIsRoundedToWholeSteps) {
  Simulation sim(sheet("implicit-midpoint"));
  const int pin = sim.core().model().pinned[0] ? 0 : 4;
  ASSERT_TRUE(sim.core().model().pinned[pin]);
  const Vec3 target = node(sim.core().state().x, pin) + Vec3(0, 0.03, 0);
  sim.move_pins({pin}, {target}, 0.0212);  // two steps
  sim.advance_to(0.02);
  EXPECT_EQ(node(sim.core().state().x, pin), target);
}

TEST(ScriptedMotion, MovingAVertexThatIsNotPinnedIsRefused) {
  Simulation sim(sheet("implicit-midpoint"));
  int free_vertex = 0;
  while (sim.core().model().pinned[free_vertex]) ++free_vertex;
  try {
    sim.move_pins({free_vertex}, {Vec3::Zero()}, 0.01);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "move_pins: vertex " + std::to_string(free_vertex) + " is not pinned");
  }
  int pin = 0;
  while (!sim.core().model().pinned[pin]) ++pin;
  EXPECT_THROW(sim.move_pins({pin}, {Vec3::Zero()}, 0.0), InputError);  // arrival not after now
  EXPECT_THROW(sim.move_collider(0, Eigen::Isometry3d::Identity(), 0.01), InputError);  // no collider
}

// A collider moved from code follows the same path as the same keyframes in the scene: the
// cloth ends the same, bit for bit.
TEST(ScriptedMotion, MovedColliderMatchesTheSceneKeyframes) {
  Scene s = sheet("implicit-midpoint");
  s.cloth.pin_grid_nodes.clear();
  s.cloth.translation = Vec3(-0.2, 0.31, 0.2);
  s.duration = 0.06;
  ColliderSpec sphere;
  sphere.shape = ColliderShape::kSphere;
  sphere.name = "colliders[0] (sphere)";
  sphere.radius = 0.3;
  s.colliders = {sphere};
  const Vec3 lift(0.01, 0.02, 0);
  Scene keyed = s;
  keyed.colliders[0].motion.kind = RigidMotion::Kind::kKeyframes;
  keyed.colliders[0].motion.keys = {{0.0, Vec3::Zero(), Vec3::Zero()}, {0.04, lift, Vec3::Zero()}};
  Simulation a(keyed), b(s);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = lift;
  b.move_collider(0, pose, 0.04);
  for (double t : {0.02, 0.04, 0.06}) {
    a.advance_to(t);
    b.advance_to(t);
  }
  EXPECT_GT(a.core().statistics().contacts, 0);
  EXPECT_EQ(a.core().state().x, b.core().state().x);
  EXPECT_LT((b.collider_pose(0, 0.06).translation() - lift).norm(), 1e-15);
}

// The integrators write positions and velocities into the State's own storage.
TEST(ScriptedMotion, StepsKeepTheStorageOfPositionsAndVelocities) {
  for (const char* method : {"implicit-midpoint", "bdf2", "rk45"}) {
    SCOPED_TRACE(method);
    Simulation sim(sheet(method));
    const double* x = sim.core().state().x.data();
    const double* v = sim.core().state().v.data();
    const VecX before = sim.core().state().x;
    sim.advance_to(0.05);
    EXPECT_NE(sim.core().state().x, before);
    EXPECT_EQ(sim.core().state().x.data(), x);
    EXPECT_EQ(sim.core().state().v.data(), v);
  }
}
