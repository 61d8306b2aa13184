// Contact with colliders (docs/collisions.md, "Response"): resting contact at the thickness,
// Coulomb friction's sticking and sliding, no energy from static frictionless contact, rigid
// motions carrying cloth, and mesh colliders telling inside from outside.
#include <gtest/gtest.h>

#include <limits>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "collision/colliders.hpp"
#include "sim/simulation_core.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

constexpr double kThickness = 0.003;

// A small horizontal square of side `size` (n x n vertices) whose lower-left corner (in x and
// -z) is at `corner`, of a linear material.
Scene patch(double size, int n, const Vec3& corner, const std::string& method = "bdf2") {
  Scene s;
  s.cloth.grid = GridSpec{size, size, n, n};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);  // the grid's y axis becomes -z
  s.cloth.translation = corner + Vec3(0, 0, size);
  s.cloth.material.weft = StressCurve::linear(200);
  s.cloth.material.warp = StressCurve::linear(200);
  s.cloth.material.shear = StressCurve::linear(20);
  s.cloth.self_collision = false;
  set_method(s, method, std::nullopt, "test");
  s.integrator.dt = 0.002;
  s.frame_interval = 0.01;
  s.duration = 0.5;
  s.integrator.cg_tolerance = 1e-10;
  s.integrator.ssor_single_precision = false;
  return s;
}

ColliderSpec floor_plane(double friction) {
  ColliderSpec c;
  c.shape = ColliderShape::kPlane;
  c.name = "floor";
  c.thickness = kThickness;
  c.friction = friction;
  return c;
}

ColliderSpec sphere(const Vec3& centre, double radius, double friction) {
  ColliderSpec c;
  c.shape = ColliderShape::kSphere;
  c.name = "sphere";
  c.centre = centre;
  c.radius = radius;
  c.thickness = kThickness;
  c.friction = friction;
  return c;
}

Vec3 centroid(const VecX& x) {
  Vec3 c = Vec3::Zero();
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) c += node(x, static_cast<int>(i));
  return c / static_cast<double>(x.size() / 3);
}

// Runs the scene (a patch over the floor plane at height 0) and expects every node to end at
// the thickness with no normal velocity, after contacts; returns the run's statistics.
StepStatistics expect_rests_on_the_floor(const Scene& s, const std::string& method) {
  Simulation sim(s);
  const RunResult r = run_simulation(sim);
  EXPECT_EQ(r.status, "ok") << method << ": " << r.message;
  const State& st = sim.core().state();
  for (int i = 0; i < sim.core().model().num_vertices(); ++i) {
    EXPECT_NEAR(st.x[3 * i + 1], kThickness, 1e-9) << method << " node " << i;
    EXPECT_NEAR(st.v[3 * i + 1], 0.0, 1e-9) << method << " node " << i;
  }
  EXPECT_GT(sim.core().statistics().contacts, 0) << method;
  return sim.core().statistics();
}

}  // namespace

TEST(ContactResponse, ClothComesToRestOnAPlaneAtTheThicknessWithNoNormalVelocity) {
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint", "alpha"}) {
    Scene s = patch(0.1, 5, Vec3(-0.05, 0.02, -0.05), method);
    s.colliders.push_back(floor_plane(0.5));
    expect_rests_on_the_floor(s, method);
  }
}

// Contact along the normal is inelastic: a flat patch thrown at the floor stops at the
// thickness and stays there, whatever the method. (A multistep method's history must not carry
// the impact on: BDF-2 repeats a third of its last change of velocity and of its last
// displacement, and from the impact's it rebounded, 6.5 mm after landing at 0.5 m/s.)
TEST(ContactResponse, ClothThrownAtAPlaneStopsAtTheThicknessWithoutRebounding) {
  for (const double speed : {0.5, 5.0})
    for (const char* method : {"bdf2", "bdf2-alpha", "backward-euler", "implicit-midpoint", "alpha"}) {
      Scene s = patch(0.1, 5, Vec3(-0.05, 0.02, -0.05), method);
      s.cloth.initial_velocity = Vec3(0, -speed, 0);
      s.integrator.dt = 0.005;
      s.duration = 0.2;
      s.colliders.push_back(floor_plane(0.5));
      Simulation sim(s);
      const std::string what = std::string(method) + " at " + std::to_string(speed) + " m/s";
      double landed = -1, highest = 0, fastest = 0;
      for (int k = 1; k <= 40; ++k) {
        sim.advance_to(k * s.integrator.dt);
        const double height = centroid(sim.positions()).y();
        if (landed < 0 && height < kThickness + 1e-6) landed = sim.time();
        if (landed < 0) continue;
        highest = std::max(highest, height);
        for (int i = 0; i < sim.vertex_count(); ++i)
          fastest = std::max(fastest, std::abs(sim.velocities()[3 * i + 1]));
      }
      ASSERT_GT(landed, 0) << what;
      // Resting at the thickness: nothing rises above it, no vertex moves along the normal.
      EXPECT_LT(highest, kThickness + 1e-6) << what << ": landed at " << landed << " s";
      EXPECT_LT(fastest, 1e-6) << what;
    }
}

// Without gravity, a cloth at rest has no energy to measure a run's by: the energy scale was
// 1e-12 J and a sphere shot through the cloth at 5 m/s stopped the linearised midpoint as
// unstable at once (5.9e-5 J "made" against it). The scale is now also the kinetic energy the
// cloth would have moving with its fastest collider.
TEST(ContactResponse, AColliderDrivingClothWithoutGravityGivesTheRunItsEnergyScale) {
  for (const char* method : {"implicit-midpoint-plain", "alpha", "bdf2"}) {
    Scene s = patch(0.2, 9, Vec3(-0.1, 0, -0.1), method);
    s.gravity = Vec3::Zero();
    s.integrator.dt = 0.005;
    s.integrator.cg_tolerance = 1e-6;
    s.duration = 0.1;
    ColliderSpec ball = sphere(Vec3(0, -0.1, 0), 0.05, 0.3);
    ball.motion.kind = RigidMotion::Kind::kVelocity;
    ball.motion.linear_velocity = Vec3(0, 5, 0);
    s.colliders.push_back(ball);
    Simulation sim(s);
    const double mass = sim.masses().sum();
    EXPECT_NEAR(sim.energy_scale(), 0.5 * mass * 25, 1e-9 * mass) << method;
    const RunResult r = run_simulation(sim);
    EXPECT_EQ(r.status, "ok") << method << ": " << r.message;
    // The sphere went through where the cloth was and carried it along.
    EXPECT_GT(centroid(sim.positions()).y(), 0.2) << method;
  }
}

// The same for a clamp: a sheet without gravity, one edge clamped and carried off at 2 m/s.
TEST(ContactResponse, AClampDrivingClothWithoutGravityGivesTheRunItsEnergyScale) {
  Scene s = patch(0.2, 9, Vec3(-0.1, 0, -0.1), "implicit-midpoint-plain");
  s.gravity = Vec3::Zero();
  s.integrator.dt = 0.005;
  s.integrator.cg_tolerance = 1e-6;
  s.duration = 0.1;
  ClampSpec edge;
  for (int i = 0; i < 9; ++i) edge.grid_nodes.emplace_back(i, 0);
  edge.motion.kind = RigidMotion::Kind::kVelocity;
  edge.motion.linear_velocity = Vec3(2, 0, 0);
  s.cloth.clamps.push_back(edge);
  Simulation sim(s);
  const double mass = sim.masses().sum();
  EXPECT_NEAR(sim.energy_scale(), 0.5 * mass * 4, 1e-9 * mass);
  const RunResult r = run_simulation(sim);
  EXPECT_EQ(r.status, "ok") << r.message;
  EXPECT_GT(centroid(sim.positions()).x(), 0.1);  // pulled along
}

// The scale is a sustained speed (displacement over 0.1 s): a collider jittering 3 cm back and
// forth at 2 m/s between its keys, going nowhere, does not drive the cloth the way a collider
// moving steadily at 2 m/s does. Its displacement over any 0.1 s is at most 3 cm, so the scale
// is at most the kinetic energy at 0.3 m/s; sampled between keys 20 ms apart, as the scale was
// before, the jitter counted as 1 m/s.
TEST(ContactResponse, AColliderJitteringInPlaceDoesNotSetTheEnergyScale) {
  Scene s = patch(0.2, 9, Vec3(-0.1, 0, -0.1), "bdf2");
  s.gravity = Vec3::Zero();
  s.duration = 0.5;
  ColliderSpec ball = sphere(Vec3(0, -0.5, 0), 0.05, 0.3);
  ball.motion.kind = RigidMotion::Kind::kKeyframes;
  for (int k = 0; k <= 40; ++k) {
    RigidMotion::Key key;
    key.time = 0.015 * k;
    key.translation = Vec3(k % 2 ? 0.03 : 0.0, 0, 0);
    ball.motion.keys.push_back(key);
  }
  s.colliders.push_back(ball);
  const Simulation jittering(s);
  const double mass = jittering.masses().sum();
  EXPECT_LE(jittering.energy_scale(), 0.5 * mass * 0.3 * 0.3 * (1 + 1e-9));
  // The same keys spread ten times as far apart in time move it steadily at 0.2 m/s over
  // 0.15 s: that is the scale (to the 20 ms sampling's rounding of the turns).
  for (RigidMotion::Key& key : s.colliders.back().motion.keys) key.time *= 10;
  const Simulation steady(s);
  EXPECT_NEAR(std::sqrt(2 * steady.energy_scale() / mass), 0.2, 0.2 * 0.15);
}

// The recorded walk's foot turns by up to 38 degrees in one motion frame around 2 s into the
// body drape (its toes moving at 10 m/s for a few milliseconds); a walk played at three
// quarters of its speed swings its feet and hands at about 3 m/s at the most, and that is
// what sets the scale of a cloth the walking body drives.
TEST(ContactResponse, TheWalkingBodysEnergyScaleIsItsSustainedSpeed) {
  Scene s = patch(0.2, 5, Vec3(2.0, 0, 2.0), "bdf2");  // far from the body, at rest
  s.gravity = Vec3::Zero();
  s.duration = 4.0;
  BodyColliderSpec walk;
  walk.speed = 0.75;
  walk.bind_pose_hold = 0.5;
  walk.blend = 0.5;
  walk.arm_spread_deg = 20;
  s.bodies.push_back(walk);
  ColliderSpec body;
  body.shape = ColliderShape::kBody;
  body.body = 0;
  body.name = "colliders[0] (body)";
  s.colliders.push_back(body);
  const Simulation sim(s);
  const double speed = std::sqrt(2 * sim.energy_scale() / sim.masses().sum());
  EXPECT_GT(speed, 1.5);
  EXPECT_LT(speed, 4.0);
}

TEST(ContactResponse, ClothRestsOnASphereAtTheThickness) {
  const Vec3 centre(0, 0, 0);
  const double radius = 0.3;
  // A patch of 1 mm (flat to 4e-7 m over the sphere) dropped from 1 mm above its top.
  Scene s = patch(0.001, 2, Vec3(-0.0005, radius + kThickness + 0.001, -0.0005));
  s.colliders.push_back(sphere(centre, radius, 1.0));
  Simulation sim(s);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "ok") << r.message;
  for (int i = 0; i < sim.core().model().num_vertices(); ++i) {
    const Vec3 p = node(sim.core().state().x, i);
    const Vec3 n = (p - centre).normalized();
    EXPECT_NEAR((p - centre).norm() - radius, kThickness, 1e-6) << "node " << i;
    EXPECT_NEAR(n.dot(node(sim.core().state().v, i)), 0.0, 1e-6) << "node " << i;
  }
}

// A patch resting on a plane under gravity tilted by theta: Coulomb friction holds it while
// tan(theta) <= friction, and otherwise it slides with acceleration g (sin theta - friction cos
// theta), the normal impulse being the weight's normal part each step.
TEST(ContactResponse, FrictionHoldsBelowTheFrictionAngleAndSlidesWithTheCoulombAccelerationAbove) {
  const double g = 9.81;
  struct Case {
    double theta_deg, friction;
  };
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"})
  for (const Case c : {Case{20, 0.5}, Case{30, 0.2}, Case{45, 0.9}, Case{45, 1.1}}) {
    SCOPED_TRACE(method);
    const double theta = c.theta_deg * M_PI / 180;
    Scene s = patch(0.1, 5, Vec3(-0.05, kThickness, -0.05), method);
    s.gravity = Vec3(g * std::sin(theta), -g * std::cos(theta), 0);
    s.colliders.push_back(floor_plane(c.friction));
    s.duration = 0.3;
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    ASSERT_EQ(r.status, "ok") << r.message;
    const double a = std::max(0.0, g * (std::sin(theta) - c.friction * std::cos(theta)));
    const double t = sim.core().state().t;
    const Vec3 mean_v = centroid(sim.core().state().v);
    const Vec3 moved = centroid(sim.core().state().x) - centroid(sim.core().model().initial_positions());
    if (a == 0) {
      // It slides during the first step only (a contact starts sliding), by at most dt^2 g.
      EXPECT_LT(std::abs(moved.x()), s.integrator.dt * s.integrator.dt * g) << c.theta_deg << " deg, friction " << c.friction;
      EXPECT_LT(std::abs(mean_v.x()), 1e-9) << c.theta_deg << " deg, friction " << c.friction;
    } else {
      EXPECT_NEAR(mean_v.x(), a * t, 1e-6 * a * t) << c.theta_deg << " deg, friction " << c.friction;
    }
    EXPECT_NEAR(mean_v.y(), 0.0, 1e-9);
  }
}

// Without friction or damping a static collider can only take energy out: the cloth's
// mechanical energy never rises above its start, and the contacts' work is not positive.
TEST(ContactResponse, FrictionlessContactWithAStaticSphereAddsNoEnergy) {
  Scene s = patch(0.3, 9, Vec3(-0.15, 0.25, -0.15), "implicit-midpoint");
  s.colliders.push_back(sphere(Vec3(0, 0, 0), 0.2, 0.0));
  s.damping_ratio = 0.0;
  s.cloth.material.viscosity_Ns_m = 0;
  s.integrator.dt = 0.001;
  s.duration = 0.4;
  Simulation sim(s);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "ok") << r.message;
  ASSERT_GT(sim.core().statistics().contacts, 0);
  const double scale = sim.energy_scale();
  for (const EnergyRow& e : r.energy) {
    EXPECT_LE(e.total(), 1e-6 * scale) << "t = " << e.time;
    EXPECT_LE(e.contact_work, 1e-6 * scale) << "t = " << e.time;
  }
}

// Newton iterations (IntegratorSettings::newton_iterations) on steps that hold contacts: the
// iterations keep the held components, so the cloth still comes to rest at the thickness with
// no normal velocity.
TEST(ContactResponse, NewtonIteratedStepsStillRestAtTheThickness) {
  for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint-plain"}) {
    Scene s = patch(0.1, 5, Vec3(-0.05, 0.03, -0.05), method);
    s.cloth.rotation_deg = Vec3(-80, 0, 8);  // tilted: it lands on a corner and is bent flat
    s.cloth.material = material_preset("cotton");  // stiffening: the linearised step is not the answer
    s.integrator.newton_iterations = 4;
    s.integrator.newton_tolerance = 1e-9;
    s.colliders.push_back(floor_plane(0.5));
    const StepStatistics st = expect_rests_on_the_floor(s, method);
    EXPECT_GT(st.newton_iterations, 0) << method;
  }
}

// A stiffening fabric dropped onto a static frictionless sphere, undamped: the linearised step
// overshoots into the steep part of the stress curve where the sheet lands (the tangent at the
// step's start is the soft one) and books the elastic energy it finds there as energy the
// integrator made; with Newton iterations on the contact steps the step's end solves the
// nonlinear equations and no energy is made.
TEST(ContactResponse, NewtonIterationsKeepAStiffeningSheetsImpactFromMakingEnergy) {
  auto made = [](int newton) {
    Scene s = patch(0.3, 17, Vec3(-0.15, 0.26, -0.15), "backward-euler");
    s.cloth.material = material_preset("cotton");
    s.cloth.material.viscosity_Ns_m = 0;
    s.damping_ratio = 0.0;
    s.colliders.push_back(sphere(Vec3(0, 0, 0), 0.2, 0.0));
    s.integrator.dt = 0.005;
    s.integrator.newton_iterations = newton;
    s.integrator.newton_tolerance = 1e-6;
    s.integrator.backward_euler_newton = false;  // 0: the linearised step throughout
    s.duration = 0.3;
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    EXPECT_EQ(r.status, "ok") << r.message;
    EXPECT_GT(sim.core().statistics().contacts, 0);
    // The energy the integrator made: the largest fall of its cumulative dissipation.
    double most = 0, highest = 0;
    for (const EnergyRow& e : r.energy) {
      highest = std::max(highest, e.numerical_dissipated);
      most = std::max(most, highest - e.numerical_dissipated);
    }
    return std::make_pair(most / sim.energy_scale(), sim.core().statistics().newton_iterations);
  };
  const auto [linearised, none] = made(0);
  const auto [newton, iterations] = made(20);
  EXPECT_EQ(none, 0);
  EXPECT_GT(iterations, 0);
  EXPECT_LT(newton, 0.1 * linearised);
  std::printf("energy made at impact, fraction of the energy scale: linearised %.3g, Newton %.3g\n", linearised, newton);
}

// The guarded midpoint's last resort (alpha at its top, halving done, energy still put in) is
// taken again with Newton iterations where the scene asks for none. A sphere driven at 4 and
// 8 m/s through a cotton sheet hanging from two corners stretches it into the steep part of
// its stress curve, where halving the step does not slow what goes in (the contact drives it)
// and backward Euler's linearised step still makes energy: kept, it made 13 to 79% of the
// energy scale (and at 8 m/s and 10 ms the run stopped as unstable); iterated, every run ends
// `ok` having made less than a hundredth of it.
TEST(ContactResponse, TheGuardedMidpointsLastResortIsIteratedWhereAStiffeningSheetIsDriven) {
  auto run = [](double speed, double dt, bool iterate, StepStatistics& st) {
    Scene s = patch(0.3, 17, Vec3::Zero(), "implicit-midpoint");
    s.cloth.rotation_deg = Vec3::Zero();  // vertical, in the xy plane
    s.cloth.translation = Vec3(-0.15, 0.0, 0);
    s.cloth.material = material_preset("cotton");
    s.cloth.pin_grid_nodes = {{0, -1}, {-1, -1}};
    s.integrator.dt = dt;
    s.integrator.guard_last_resort_newton = iterate;
    s.duration = 0.3;
    ColliderSpec c = sphere(Vec3(0, 0.15, -0.15), 0.08, 0.3);
    c.motion.kind = RigidMotion::Kind::kVelocity;
    c.motion.linear_velocity = Vec3(0, 0, speed);
    s.colliders.push_back(c);
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    st = sim.core().statistics();
    double most = 0, highest = 0;
    for (const EnergyRow& e : r.energy) {
      highest = std::max(highest, e.numerical_dissipated);
      most = std::max(most, highest - e.numerical_dissipated);
    }
    return std::make_pair(r.status, most / sim.energy_scale());
  };
  for (const double speed : {4.0, 8.0})
    for (const double dt : {0.005, 0.01}) {
      char what_text[64];
      std::snprintf(what_text, sizeof what_text, "%g m/s, dt = %g s", speed, dt);
      const std::string what = what_text;
      StepStatistics kept_st, iterated_st;
      const auto [kept_status, kept] = run(speed, dt, false, kept_st);
      const auto [status, iterated] = run(speed, dt, true, iterated_st);
      EXPECT_EQ(kept_st.guard_newton_steps, 0) << what;
      EXPECT_EQ(kept_st.newton_iterations, 0) << what;
      if (kept_status == "ok") EXPECT_GT(kept, 0.1) << what << ": the linearised last resort makes energy";
      EXPECT_EQ(status, "ok") << what;
      EXPECT_GT(iterated_st.guard_newton_steps, 0) << what;
      EXPECT_GT(iterated_st.newton_iterations, 0) << what;
      EXPECT_LT(iterated, 0.01) << what;
      std::printf("%s: energy made, fraction of the scale: kept %.3g (%s), iterated %.3g (%ld last resorts)\n",
                  what.c_str(), kept, kept_status.c_str(), iterated, iterated_st.guard_newton_steps);
    }
}

TEST(ContactResponse, ASpinningSphereCarriesTheClothOnItRoundByFriction) {
  const double radius = 0.3, omega = 1.0;  // rad/s about the vertical through the centre
  Scene s = patch(0.04, 3, Vec3(0.08, radius + 0.002, -0.02));  // 10 cm from the axis
  ColliderSpec c = sphere(Vec3::Zero(), radius, 2.0);
  c.motion.kind = RigidMotion::Kind::kVelocity;
  c.motion.angular_velocity = Vec3(0, omega, 0);
  s.colliders.push_back(c);
  s.duration = 1.0;
  s.frame_interval = 0.25;
  Simulation sim(s);
  std::vector<double> angle;  // of the patch's centroid about the axis, per frame
  RunCallbacks cb;
  cb.on_frame = [&](int, const Simulation& at) {
    const Vec3 c = centroid(at.core().state().x);
    angle.push_back(std::atan2(-c.z(), c.x()));
  };
  const RunResult r = run_simulation(sim, cb);
  ASSERT_EQ(r.status, "ok") << r.message;
  ASSERT_EQ(angle.size(), 5u);
  // Once it has landed (it falls 2 cm onto the sphere's slope) and stuck, the patch turns with
  // the surface.
  EXPECT_NEAR((angle[4] - angle[2]) / 0.5, omega, 0.02 * omega);
  EXPECT_GT(sim.core().statistics().contacts, 0);
}

TEST(RigidMotion, VelocityMovesTheCentreAndTurnsAboutIt) {
  RigidMotion m;
  m.kind = RigidMotion::Kind::kVelocity;
  m.linear_velocity = Vec3(1, 2, 3);
  m.angular_velocity = Vec3(0, 0, 0.5);
  m.centre = Vec3(1, 0, 0);
  const Eigen::Isometry3d T = m.at(2.0);
  EXPECT_LT((T * m.centre - (m.centre + 2.0 * m.linear_velocity)).norm(), 1e-12);
  // A point 1 m from the centre along x turns by 1 rad about z.
  const Vec3 p = T * (m.centre + Vec3(1, 0, 0)) - T * m.centre;
  EXPECT_LT((p - Vec3(std::cos(1.0), std::sin(1.0), 0)).norm(), 1e-12);
}

TEST(RigidMotion, KeyframesAreHitAndInterpolatedAndHeldOutside) {
  RigidMotion m;
  m.kind = RigidMotion::Kind::kKeyframes;
  m.keys = {{1.0, Vec3(0, 0, 0), Vec3(0, 0, 0)}, {3.0, Vec3(2, 0, 0), Vec3(0, 90, 0)}};
  EXPECT_LT((m.at(0.0).translation() - Vec3::Zero()).norm(), 1e-12);  // held before the first
  EXPECT_LT((m.at(2.0).translation() - Vec3(1, 0, 0)).norm(), 1e-12);
  const Vec3 x = m.at(2.0).linear() * Vec3::UnitX();
  EXPECT_LT((x - Vec3(std::cos(M_PI / 4), 0, -std::sin(M_PI / 4))).norm(), 1e-12);  // half of 90 deg about y
  EXPECT_LT((m.at(5.0).matrix() - m.at(3.0).matrix()).norm(), 1e-12);  // held after the last
}

// A closed mesh collider (a cube of side 1 about the origin, outward-wound) answers signed
// distances: outside positive, inside negative, with the outward normal.
TEST(MeshCollider, ClosedMeshTellsInsideFromOutsideEverywhere) {
  Points cube(8, 3);
  for (int k = 0; k < 8; ++k) cube.row(k) << ((k & 1) ? 0.5 : -0.5), ((k & 2) ? 0.5 : -0.5), ((k & 4) ? 0.5 : -0.5);
  Triangles t(12, 3);
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (int f = 0; f < 6; ++f) {
    t.row(2 * f) << faces[f][0], faces[f][1], faces[f][2];
    t.row(2 * f + 1) << faces[f][0], faces[f][2], faces[f][3];
  }
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  auto analytic_spec = spec;
  analytic_spec.shape = ColliderShape::kBox;
  analytic_spec.half_extents = Vec3::Constant(0.5);
  const auto mesh = make_mesh_collider(spec, t, [&](double, Points& out) { out = cube; }, true);
  const auto box = make_analytic_collider(analytic_spec);
  mesh->prepare(0, 0.01);
  box->prepare(0, 0.01);
  std::srand(7);
  for (int k = 0; k < 2000; ++k) {
    const Vec3 p = Vec3::Random() * 0.9;  // inside, outside, near faces, edges and corners
    SurfacePoint a, b;
    ASSERT_TRUE(mesh->closest(p, 10, false, 0, a));
    ASSERT_TRUE(box->closest(p, 10, false, 0, b));
    EXPECT_NEAR(a.distance, b.distance, 1e-12) << p.transpose();
    if (std::abs(a.distance) > 1e-9) EXPECT_LT((a.normal - b.normal).norm(), 1e-9) << p.transpose();
  }
}

TEST(MeshCollider, TheNearestOfAWideAndASmallTriangleIsFound) {
  // A small triangle 1.56 cm from the point, in the corner of the cube of 2.5 thicknesses
  // around it, and a wide one 1.2 cm away along x, outside that cube: the wide one is the
  // answer (a search that looked in the small cube first and stopped there would miss it).
  Points p(6, 3);
  p << 0.012, -0.05, -0.05, 0.012, 0.05, -0.05, 0.012, 0.0, 0.08,  // wide, in the plane x = 1.2 cm
      0.009, 0.009, 0.009, 0.0095, 0.009, 0.009, 0.009, 0.0095, 0.009;  // small, in the corner
  Triangles t(2, 3);
  t << 0, 1, 2, 3, 4, 5;
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  spec.thickness = 0.004;
  const auto mesh = make_mesh_collider(spec, t, [&](double, Points& out) { out = p; }, false);
  mesh->prepare(0, 0.01);
  SurfacePoint a;
  ASSERT_TRUE(mesh->closest(Vec3::Zero(), 0.03, false, 0, a));
  EXPECT_NEAR(std::abs(a.distance), 0.012, 1e-12);
  EXPECT_NEAR(a.point.x(), 0.012, 1e-12);
  // From next to the corner's triangle, that one; with a reach short of both, nothing.
  ASSERT_TRUE(mesh->closest(Vec3(0.009, 0.009, 0.0085), 0.03, false, 1, a));
  EXPECT_NEAR(std::abs(a.distance), 0.0005, 1e-12);
  EXPECT_FALSE(mesh->closest(Vec3::Zero(), 0.011, false, 2, a));
}

// Clamps: a clamped vertex is on its clamp's path at every frame (turning and travelling),
// whatever the method, and the energy balance closes with the clamps' work booked to the
// contacts: work in = elastic + kinetic + gravity change + what damping and the method took.
TEST(ClampedCloth, VerticesFollowTheirClampsAndTheEnergyBalanceCloses) {
  for (const char* method : {"bdf2", "implicit-midpoint", "backward-euler", "rk4"}) {
    SCOPED_TRACE(method);
    Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/twisted-sheet.json");
    scene.cloth.grid->vertices_u = 13;
    scene.cloth.grid->vertices_v = 7;
    for (ClampSpec& c : scene.cloth.clamps)
      for (auto& g : c.grid_nodes) g.second = std::min(g.second, 6);
    scene.cloth.self_collision = false;
    set_method(scene, method, std::nullopt, "test");
    if (std::string(method) == "rk4") scene.integrator.dt = 2e-4;
    scene.duration = 0.3;
    Simulation sim(scene);
    const std::vector<int> left = {0, 13, 26, 39, 52, 65, 78};
    double worst = 0;
    RunCallbacks cb;
    cb.on_frame = [&](int, const Simulation& s) {
      const double t = s.core().state().t;
      const Eigen::Isometry3d T = scene.cloth.clamps[0].motion.at(t);
      for (int i : left) {
        const Vec3 rest = node(s.core().model().initial_positions(), i);
        worst = std::max(worst, (node(s.core().state().x, i) - T * rest).norm());
      }
    };
    const RunResult r = run_simulation(sim, cb);
    ASSERT_EQ(r.status, "ok") << r.message;
    EXPECT_LT(worst, 1e-9);
    const EnergyRow& e = r.energy.back();
    // The clamps did work (they twist the sheet), and booked as the contacts' work it accounts
    // for the energy the sheet gained: what is left for the method to have created is a small
    // part of it (unbooked, it would all show as negative numerical dissipation).
    EXPECT_GT(e.contact_work, 1e-4);
    EXPECT_GT(e.numerical_dissipated, -0.01 * e.contact_work) << e.contact_work;
  }
}

// A box with rounded edges is its inner box grown by the radius: the signed distance is the
// distance to the inner box less the radius outside it, and the nearest face's depth inside
// it (a point a radius from the inner box is on the surface, whichever face, edge or corner it
// is nearest). Its drawn surface has every vertex on that surface, wound outwards.
TEST(BoxCollider, RoundedEdgesAreTheInnerBoxGrownByTheRadius) {
  ColliderSpec spec;
  spec.shape = ColliderShape::kBox;
  spec.centre = Vec3(0.1, 0.2, -0.3);
  spec.half_extents = Vec3(0.5, 0.2, 0.3);
  spec.rotation_deg = Vec3(10, 20, 30);
  spec.edge_radius = 0.05;
  const auto box = make_analytic_collider(spec);
  const Mat3 R = rotation_from_degrees(spec.rotation_deg);
  const Vec3 inner = spec.half_extents - Vec3::Constant(spec.edge_radius);
  std::srand(11);
  for (int k = 0; k < 2000; ++k) {
    const Vec3 q = Vec3::Random().cwiseProduct(spec.half_extents + Vec3::Constant(0.1));
    const Vec3 p = spec.centre + R * q;
    SurfacePoint s;
    ASSERT_TRUE(box->closest(p, 10, false, 0, s));
    const Vec3 outside = q - q.cwiseMax(-inner).cwiseMin(inner);
    const double depth = (spec.half_extents - q.cwiseAbs()).minCoeff();
    const double expected = outside.norm() > 0 ? outside.norm() - spec.edge_radius : -depth;
    EXPECT_NEAR(s.distance, expected, 1e-12) << q.transpose();
    EXPECT_NEAR(s.normal.norm(), 1, 1e-12);
    EXPECT_LT((s.point + s.distance * s.normal - p).norm(), 1e-12) << q.transpose();
  }
  Points positions;
  Triangles triangles;
  box->surface(0, positions, triangles);
  ASSERT_GT(triangles.rows(), 12);
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    SurfacePoint s;
    ASSERT_TRUE(box->closest(positions.row(v).transpose(), 10, false, 0, s));
    EXPECT_NEAR(s.distance, 0, 1e-12);
  }
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const Vec3 a = positions.row(triangles(f, 0)), b = positions.row(triangles(f, 1)), c = positions.row(triangles(f, 2));
    const Vec3 normal = (b - a).cross(c - a);
    if (normal.norm() < 1e-12) continue;  // a corner's collapsed grid cell
    EXPECT_GT(normal.dot((a + b + c) / 3 - spec.centre), 0) << "triangle " << f << " faces inwards";
  }
}

// A box's surface point nearest a triangle (what lifts cloth faces off its edges): its distance
// is the least over the triangle's points, checked against a dense sampling of the triangle,
// for triangles outside the box, over its rounded edges and corners, and for sharp edges.
TEST(BoxCollider, SurfacePointNearestATriangleIsTheTrianglesNearest) {
  for (double radius : {0.0, 0.05}) {
    ColliderSpec spec;
    spec.shape = ColliderShape::kBox;
    spec.half_extents = Vec3(0.3, 0.2, 0.25);
    spec.rotation_deg = Vec3(0, 30, 0);
    spec.edge_radius = radius;
    const auto box = make_analytic_collider(spec);
    box->prepare(0, 0.01);
    std::srand(5);
    int checked = 0;
    for (int k = 0; k < 300; ++k) {
      const Vec3 centre = Vec3::Random().cwiseProduct(spec.half_extents + Vec3::Constant(0.08));
      const Vec3 a = centre + 0.05 * Vec3::Random(), b = centre + 0.05 * Vec3::Random(), c = centre + 0.05 * Vec3::Random();
      SurfacePoint s;
      Vec3 w;
      ASSERT_TRUE(box->closest_to_triangle(a, b, c, s, w));
      double least = std::numeric_limits<double>::infinity();
      const int n = 60;
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
          SurfacePoint q;
          box->closest((i * a + j * b + (n - i - j) * c) / n, 10, true, 0, q);
          least = std::min(least, q.distance);
        }
      if (least <= 0) continue;  // triangles reaching inside are only lifted by their deepest face
      ++checked;
      EXPECT_LE(s.distance, least + 1e-9) << k;
      EXPECT_GE(s.distance, least - 0.004) << k;  // the sampling's spacing of about 2 mm
      const Vec3 point = w[0] * a + w[1] * b + w[2] * c;
      EXPECT_NEAR(w.sum(), 1, 1e-12);
      EXPECT_LT((s.point + s.distance * s.normal - point).norm(), 1e-6) << k;
    }
    EXPECT_GT(checked, 50);
  }
}

// An open mesh (a square plate of two triangles) holds the cloth on the side it falls from,
// whichever way its triangles are wound.
TEST(MeshCollider, OpenPlateHoldsTheClothOnItsSideWhicheverWayItIsWound) {
  const std::string obj = ::testing::TempDir() + "weft_open_plate_" + std::to_string(::getpid()) + ".obj";
  for (bool up : {true, false}) {
    {
      std::ofstream out(obj);
      out << "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
          << (up ? "f 1 3 2\nf 1 4 3\n" : "f 1 2 3\nf 1 3 4\n");  // normals +y, or -y
    }
    Scene s = patch(0.1, 5, Vec3(-0.05, 0.02, -0.05));
    ColliderSpec spec;
    spec.shape = ColliderShape::kMesh;
    spec.obj_path = obj;
    spec.thickness = kThickness;
    spec.closed = false;
    s.colliders.push_back(spec);
    Simulation sim(s);
    const RunResult r = run_simulation(sim);
    ASSERT_EQ(r.status, "ok") << r.message;
    for (int i = 0; i < sim.core().model().num_vertices(); ++i)
      EXPECT_NEAR(sim.core().state().x[3 * i + 1], kThickness, 1e-6) << (up ? "up" : "down") << " node " << i;
    EXPECT_EQ(sim.core().statistics().fail_safe_moves, 0) << (up ? "up" : "down");
  }
  std::remove(obj.c_str());
}

// A closed mesh thinner than the step's travel (a plate 5 mm thick, against 2.5 cm per 5 ms
// step at 5 m/s) is not passed through, whichever side moves: cloth thrown at the resting plate
// at 5 m/s, and the plate driven at 5 m/s up into resting cloth, ends every step on the
// plate's near side, at the thickness once it rests there. (Inside and outside are told apart
// by the nearest surface, so a vertex that ended a step past the plate's middle would come out
// on the far side: the contacts are found at the step's start, on the right side.)
TEST(MeshCollider, AThinClosedPlateIsNotPassedThroughAtFiveMetresPerSecond) {
  const std::string obj = ::testing::TempDir() + "weft_thin_plate_" + std::to_string(::getpid()) + ".obj";
  const double half = 0.0025;  // the plate's half thickness
  {
    std::ofstream out(obj);
    // A box 0.4 m x 5 mm x 0.4 m about the origin, its triangles counter-clockwise from outside.
    for (int k = 0; k < 8; ++k)
      out << "v " << (k & 4 ? 0.2 : -0.2) << " " << (k & 2 ? half : -half) << " " << (k & 1 ? 0.2 : -0.2) << "\n";
    out << "f 1 2 4\nf 1 4 3\nf 5 7 8\nf 5 8 6\nf 1 5 6\nf 1 6 2\n"
        << "f 3 4 8\nf 3 8 7\nf 1 3 7\nf 1 7 5\nf 2 6 8\nf 2 8 4\n";
  }
  for (const bool plate_moves : {false, true})
    for (const char* method : {"bdf2", "backward-euler", "implicit-midpoint"}) {
      const std::string what = std::string(method) + (plate_moves ? ", the plate driven up" : ", the cloth thrown");
      // Placed so that a step without contacts would end past the plate's middle (1 to 1.5 mm).
      Scene s = patch(0.1, 6, Vec3(-0.05, plate_moves ? 0.0485 : 0.024, -0.05), method);
      s.gravity = Vec3::Zero();
      s.integrator.dt = 0.005;
      s.duration = 0.1;
      ColliderSpec spec;
      spec.shape = ColliderShape::kMesh;
      spec.obj_path = obj;
      spec.thickness = kThickness;
      spec.friction = 0.3;
      if (plate_moves) {
        spec.motion.kind = RigidMotion::Kind::kVelocity;
        spec.motion.linear_velocity = Vec3(0, 5, 0);
      } else {
        s.cloth.initial_velocity = Vec3(0, -5, 0);
      }
      s.colliders.push_back(spec);
      Simulation sim(s);
      double lowest = std::numeric_limits<double>::infinity();
      for (int k = 1; k <= 20; ++k) {
        sim.advance_to(k * s.integrator.dt);
        const double top = half + (plate_moves ? 5.0 * sim.time() : 0.0);
        for (int i = 0; i < sim.vertex_count(); ++i) lowest = std::min(lowest, sim.positions()[3 * i + 1] - top);
      }
      // Every node above the plate's top face in every step, and at the end resting at the
      // thickness over it (the plate's velocity along the normal, the cloth's own relative one).
      EXPECT_GT(lowest, 0.5 * kThickness) << what;
      const double top = half + (plate_moves ? 5.0 * sim.time() : 0.0);
      for (int i = 0; i < sim.vertex_count(); ++i)
        EXPECT_NEAR(sim.positions()[3 * i + 1] - top, kThickness, 1e-6) << what << " node " << i;
    }
  std::remove(obj.c_str());
}
