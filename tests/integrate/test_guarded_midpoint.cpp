// The energy guard of Implicit Midpoint (docs/guarded-midpoint.md): a step whose energy balance
// shows that it put energy in is taken again as two halves, then with a larger alpha.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "support/spinning_spring.hpp"
#include "support/spring_system.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;
using weft::test::mechanical_energy;
using weft::test::spinning_spring_state;

namespace {

IntegratorSettings midpoint(double dt, bool guard) {
  IntegratorSettings st;
  st.alpha = 0.5;
  st.dt = dt;
  st.cg_tolerance = 1e-12;
  st.guard = guard;
  return st;
}

// 1 kg on a spring of 1 m and 10^6 N/m going round at 5 m/s, 200 steps of 20 ms (kappa 400, a
// quarter turn every 8 steps): the linearised step, whose Jacobian points along the spring at
// the step's start, stretches the spring it turns.
struct Spin {
  double start = 0, highest = 0, end = 0;
  int steps_gaining = 0;  ///< steps that put in more than the guard's tolerance
  StepStatistics stats;
};
Spin spin(const IntegratorSettings& settings) {
  const double k = 1e6;
  SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
  State s = spinning_spring_state(k, 5.0);
  Integrator in(sys, settings);
  Spin r;
  r.start = r.highest = r.end = mechanical_energy(sys, s);
  for (int n = 0; n < 200; ++n) {
    in.step(s, settings.dt, r.stats);
    const double next = mechanical_energy(sys, s);
    // No energy scale was set, so the guard's tolerance is a fraction of the state's own
    // (kinetic plus elastic) energy; the margin covers this test's own rounding.
    if (next > r.end * (1 + kGuardTolerance) + 1e-12 * r.end) ++r.steps_gaining;
    r.end = next;
    r.highest = std::max(r.highest, next);
  }
  return r;
}

// Zero-rest-length springs are linear: a chain of them under gravity, 100 steps of 50 ms.
State linear_chain_end(const IntegratorSettings& settings, StepStatistics& st) {
  const std::vector<Spring> chain = {{0, -1, 30.0, 0.0, 0.4}, {0, 1, 20.0, 0.0, 0.7}, {1, 2, 45.0, 0.0, 0.3}};
  VecX mass(3);
  mass << 0.2, 0.35, 0.15;
  State s;
  s.x = VecX(9);
  s.x << 0.3, -0.2, 0.1, 0.9, -0.5, -0.2, 1.4, -0.1, 0.4;
  s.v = VecX(9);
  s.v << 0.5, 1.2, -0.3, -0.8, 0.2, 0.6, 0.1, -1.1, 0.9;
  SpringSystem sys(mass, chain, Vec3(0, -9.81, 0));
  Integrator in(sys, settings);
  for (int n = 0; n < 100; ++n) in.step(s, settings.dt, st);
  return s;
}

// 1 kg at rest at the end of a spring of 1 m and 10^4 N/m from the origin, at its rest length,
// stepped by the guarded midpoint at 10 ms against an energy scale of 1 J.
struct NodeAtRest {
  SpringSystem sys{VecX::Constant(1, 1.0), {Spring{0, -1, 1e4, 1.0, 0.0}}};
  State s;
  Integrator in{sys, midpoint(0.01, true)};
  NodeAtRest() {
    s.x = Vec3(1, 0, 0);
    s.v = Vec3::Zero();
    in.set_energy_scale(1.0);
  }
};

void expect_same_bits(const State& a, const State& b) {
  EXPECT_TRUE((a.x.array() == b.x.array()).all());
  EXPECT_TRUE((a.v.array() == b.v.array()).all());
  EXPECT_EQ(a.viscous_dissipated, b.viscous_dissipated);
}

}  // namespace

TEST(GuardedMidpoint, StiffSpinningSpringGainsEnergyOnlyWithoutTheGuard) {
  const Spin plain = spin(midpoint(0.02, false)), guarded = spin(midpoint(0.02, true));
  EXPECT_GT(plain.highest, 1.5 * plain.start);
  EXPECT_EQ(guarded.steps_gaining, 0);
  EXPECT_GT(guarded.stats.guard_split_steps, 0);
  EXPECT_LE(guarded.highest, guarded.start * (1 + 200 * kGuardTolerance));
  EXPECT_LT(guarded.end, guarded.start);
}

// A contact that lifts a node 10 cm off the line of its spring in one step, whatever the step's
// size. The spring is at its rest length, so the linearised step sees no sideways stiffness and
// books none of the stretch's elastic energy as the contact's work: the step puts that energy
// in, and a half step puts in all of it again.
class LiftingWall : public ContactHandler {
 public:
  static constexpr double kHeight = 0.1;
  void detect(const VecX& x, const VecX& /*v*/, double /*t*/, double /*dt*/, std::vector<NodeContact>& out) override {
    NodeContact c;
    c.node = 0;
    c.normal = Vec3::UnitY();
    c.normal_displacement = std::max(0.0, kHeight - x[1]);
    out.push_back(c);
  }
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX&, VecX&, double, double, ContactReport&) override {}
};

TEST(GuardedMidpoint, AStepAContactPutsEnergyIntoWhateverItsSizeIsNotHalved) {
  const double k = 1e4;
  NodeAtRest n;
  State& s = n.s;
  Integrator& in = n.in;
  LiftingWall wall;
  in.add_contact_handler(&wall);
  StepStatistics st;
  in.step(s, 0.01, st);
  EXPECT_NEAR(s.x[1], LiftingWall::kHeight, 1e-9);
  // The stretch's energy, far above the guard's tolerance of 1e-4 J, whatever the step's size.
  const double stretch = std::sqrt(1 + LiftingWall::kHeight * LiftingWall::kHeight) - 1;
  EXPECT_GT(0.5 * k * stretch * stretch, 1000 * kGuardTolerance);
  // The first half put in as much as the whole step: no halving; the whole step is taken
  // again at a larger alpha (whose own numerical dissipation of the lift outweighs the
  // stretch), in one part, and the next step starts whole.
  EXPECT_EQ(st.guard_futile_splits, 1);
  EXPECT_EQ(st.guard_split_steps, 0);
  EXPECT_EQ(st.guard_parts, 1);
  EXPECT_GE(st.guard_redone_steps, 1);
  EXPECT_EQ(in.data().guard_depth, 0);
}

// A fail-safe that moves a node and sends it off sideways at `speed` after every solve, putting in
// half the node's mass times speed^2 of kinetic energy (and a little elastic energy) each step.
class KickingFailSafe : public ContactHandler {
 public:
  explicit KickingFailSafe(double speed) : speed_(speed) {}
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>&) override {}
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX& x1, VecX& v1, double, double dt, ContactReport& report) override {
    x1[2] += speed_ * dt;
    v1[2] = speed_;
    ++report.fail_safe_moves;
  }

 private:
  double speed_;
};

// The fail-safes' work is contact work, which the guard's balance leaves out, until one step's
// exceeds kGuardFailSafeShare of the energy scale: then the guard counts it as energy the step
// put in and takes the step again at larger alphas (the kick comes back in every attempt, so
// the last rung is kept).
TEST(GuardedMidpoint, AStepWhoseFailSafesPutInASizeableShareOfTheScaleIsTakenAgainAtLargerAlphas) {
  for (const double share : {0.5, 2.0}) {
    NodeAtRest n;
    State& s = n.s;
    Integrator& in = n.in;
    // Kinetic energy 0.5 speed^2 = share times the threshold.
    KickingFailSafe kick(std::sqrt(2 * share * kGuardFailSafeShare));
    in.add_contact_handler(&kick);
    StepStatistics st;
    in.step(s, 0.01, st);
    EXPECT_GT(s.fail_safe_work, 0.5 * share * kGuardFailSafeShare);
    if (share < 1) {
      EXPECT_EQ(st.guard_redone_steps, 0) << share;
      EXPECT_EQ(st.guard_parts, 1) << share;
    } else {
      // Every rung above the scene's alpha was tried; the step ends on the last (alpha 1).
      EXPECT_EQ(st.guard_redone_steps, static_cast<long>(std::size(kGuardAlphas))) << share;
      EXPECT_EQ(in.data().guard_rung, static_cast<int>(std::size(kGuardAlphas))) << share;
    }
  }
}

// A frictionless contact on a node that does not slide: the node leaves the step at the
// surface's velocity (friction's share of a zero sliding speed is zero, not 0/0).
TEST(GuardedMidpoint, AFrictionlessContactOnANodeThatDoesNotSlideLeavesItAtTheSurfacesVelocity) {
  SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, 1e4, 1.0, 0.0}});
  State s;
  s.x = Vec3(1, 0, 0);
  s.v = Vec3::Zero();
  Integrator in(sys, midpoint(0.01, false));
  LiftingWall wall;
  in.add_contact_handler(&wall);
  StepStatistics st;
  in.step(s, 0.01, st);
  EXPECT_NEAR(s.x[1], LiftingWall::kHeight, 1e-9);
  EXPECT_EQ(s.v, VecX(Vec3::Zero()));
}

// Without contacts a step that puts energy in is halved as far as it may, whatever its halves
// put in: the stiff spinning spring's steps are.
TEST(GuardedMidpoint, WithoutContactsAStepIsHalvedAsBefore) {
  const Spin guarded = spin(midpoint(0.02, true));
  EXPECT_EQ(guarded.stats.guard_futile_splits, 0);
  EXPECT_GT(guarded.stats.guard_split_steps, 0);
}

// A frictionless contact that holds the spinning spring's mass in its plane of turning (the
// normal across the plane, nothing to prescribe): the spring turns as before, but contacts act
// in every attempt.
class PlaneOfTurning : public ContactHandler {
 public:
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>& out) override {
    NodeContact c;
    c.node = 0;
    c.normal = Vec3::UnitZ();
    out.push_back(c);
  }
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX&, VecX&, double, double, ContactReport&) override {}
};

// A contact that lifts a node lying on its spring's line by lift * (dt / 10 ms)^(3/8) in a step
// of dt (a node already lifted is left alone): the stretch's elastic energy, which the
// linearised step does not book as the contact's work, goes as dt^(3/2), so a half step puts in
// 0.35 of what the whole did, not the eighth or less of a stiff turning element.
class GrowingLift : public ContactHandler {
 public:
  explicit GrowingLift(double lift) : lift_(lift) {}
  void detect(const VecX& x, const VecX&, double, double dt, std::vector<NodeContact>& out) override {
    if (x[1] > 0.25 * lift_) return;
    NodeContact c;
    c.node = 0;
    c.normal = Vec3::UnitY();
    c.normal_displacement = lift_ * std::pow(dt / 0.01, 0.375);
    out.push_back(c);
  }
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX&, VecX&, double, double, ContactReport&) override {}

 private:
  double lift_;
};

// The steps after a halving start as finely divided where its halves showed stiff turning
// elements (each half a quarter of the whole's energy at most), contacts or not; where contacts
// acted and the halves did not show it, the next step starts whole.
TEST(GuardedMidpoint, AHalvingIsCarriedIntoTheNextStepsWhereItsHalvesShowTurningElements) {
  for (const bool held : {false, true}) {
    const double k = 1e6;
    SpringSystem sys(VecX::Constant(1, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
    State s = spinning_spring_state(k, 5.0);
    Integrator in(sys, midpoint(0.02, true));
    PlaneOfTurning plane;
    if (held) in.add_contact_handler(&plane);
    StepStatistics st;
    const double start = mechanical_energy(sys, s);
    int deepest = 0;
    for (int n = 0; n < 200; ++n) {
      in.step(s, 0.02, st);
      deepest = std::max(deepest, in.data().guard_depth);
    }
    EXPECT_GT(st.guard_split_steps, 0) << held;
    EXPECT_GT(deepest, 0) << held;
    EXPECT_EQ(s.x[2], 0.0) << held;
    EXPECT_LT(mechanical_energy(sys, s), start) << held;
    EXPECT_EQ(st.contacts > 0, held);
  }
  // The lift of 2 cm puts in twice the guard's tolerance in a step of 10 ms (k/8 lift^4 at the
  // spring's rest length), 0.35 of that in its first half and nothing in the second.
  NodeAtRest n;
  State& s = n.s;
  Integrator& in = n.in;
  GrowingLift lift(0.02);
  in.add_contact_handler(&lift);
  StepStatistics st;
  in.step(s, 0.01, st);
  EXPECT_EQ(st.guard_split_steps, 1);
  EXPECT_EQ(st.guard_futile_splits, 0);
  EXPECT_EQ(st.guard_parts, 2);
  EXPECT_EQ(in.data().guard_depth, 0);
  EXPECT_NEAR(s.x[1], 0.02 * std::pow(0.5, 0.375), 1e-5);  // lifted once, by the first half
  in.step(s, 0.01, st);  // nothing lifts: one part
  EXPECT_EQ(st.guard_parts, 3);
}

// A solve that stops at the iteration cap counts as failed (summary.json's solver_failures,
// the solver_capped status) only in an attempt the guard keeps: with no iteration allowed every
// solve stops at the cap, and the spinning spring makes the guard take steps again.
TEST(GuardedMidpoint, OnlyTheKeptAttemptsSolvesCountAsFailed) {
  IntegratorSettings settings = midpoint(0.02, true);
  settings.cg_max_iterations = 0;
  const StepStatistics st = spin(settings).stats;
  EXPECT_GT(st.cg_solves, st.guard_parts);  // attempts were taken again
  EXPECT_GT(st.cg_failures, 0);
  EXPECT_LE(st.cg_failures, st.guard_parts);  // one solve per part kept: no contacts
}

TEST(GuardedMidpoint, SameResultsAsThePlainStepWhereTheGuardNeverActs) {
  // On a linear system Implicit Midpoint's energy changes by exactly the viscous work it
  // books: only rounding is left for the guard to see.
  StepStatistics plain_stats, guarded_stats;
  const State plain = linear_chain_end(midpoint(0.05, false), plain_stats);
  const State guarded = linear_chain_end(midpoint(0.05, true), guarded_stats);
  EXPECT_EQ(guarded_stats.guard_split_steps + guarded_stats.guard_redone_steps + guarded_stats.guard_raised_steps, 0);
  expect_same_bits(plain, guarded);
}

TEST(GuardedMidpoint, EnergyBalanceClosesWhereTheGuardActs) {
  // The 21x21 swing, where plain Implicit Midpoint blows up within a second: the guard takes
  // steps again, and the account must not book a discarded attempt's viscous work. Every
  // accepted (part) step puts in at most kGuardTolerance of the scale, so the numerical
  // dissipation can fall below zero by no more than that much per step and half step.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing-21x21.json");
  scene.duration = 1.0;
  Simulation sim(scene);
  const RunResult r = run_simulation(sim);
  ASSERT_EQ(r.status, "ok") << r.message;
  EXPECT_GT(r.steps.guard_split_steps, 0);
  double scale = sim.energy_scale();
  for (const EnergyRow& e : r.energy) scale = std::max(scale, e.kinetic + e.elastic);
  const double parts = static_cast<double>(r.steps.steps + r.steps.guard_split_steps);
  for (const EnergyRow& e : r.energy) {
    EXPECT_GE(e.numerical_dissipated, -parts * kGuardTolerance * scale) << "t = " << e.time;
    EXPECT_GE(e.viscous_dissipated, 0.0);
  }
  // energy.csv reports the guard frame by frame: the parts taken so far (as many as the
  // steps, or more where the guard split them) and the alpha the next step starts at.
  double parts_so_far = 0;
  for (const EnergyRow& e : r.energy) {
    EXPECT_GE(e.guard_parts, parts_so_far) << "t = " << e.time;
    parts_so_far = e.guard_parts;
    EXPECT_GE(e.guard_alpha, 0.5);
    EXPECT_LE(e.guard_alpha, 1.0);
  }
  EXPECT_EQ(parts_so_far, static_cast<double>(r.steps.guard_parts));
  EXPECT_GT(parts_so_far, static_cast<double>(r.steps.steps)) << "the guard split steps";
  const std::string csv = energy_csv(r.energy);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,contact_work,total,guard_parts,guard_alpha");
  // The plain step on the same scene is not stable: the guard is what keeps it; its rows have
  // no guard columns.
  set_method(scene, "implicit-midpoint-plain", std::nullopt, "test");
  Simulation plain(scene);
  const RunResult p = run_simulation(plain);
  EXPECT_EQ(p.status, "unstable");
  const std::string plain_csv = energy_csv(p.energy);
  EXPECT_EQ(plain_csv.substr(0, plain_csv.find('\n')),
            "time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,contact_work,total");
}

// The same guard on BDF-2 at alpha = 1/sqrt(3) (bdf2-alpha-guarded): a step that puts energy in
// is taken again with a larger alpha, up to standard BDF-2, then as a backward Euler step, then
// as backward Euler halves.
namespace {

IntegratorSettings bdf2_alpha(double dt, bool guard) {
  IntegratorSettings st = midpoint(dt, guard);
  st.method = Method::kBdf2;
  st.alpha = 1.0 / std::sqrt(3.0);
  return st;
}

}  // namespace

TEST(GuardedBdf2, StiffSpinningSpringGainsEnergyOnlyWithoutTheGuard) {
  const Spin plain = spin(bdf2_alpha(0.02, false)), guarded = spin(bdf2_alpha(0.02, true));
  EXPECT_GT(plain.highest, 1.5 * plain.start);
  EXPECT_EQ(guarded.steps_gaining, 0);
  EXPECT_GT(guarded.stats.guard_redone_steps, 0) << "larger alphas, then backward Euler";
  EXPECT_GT(guarded.stats.guard_split_steps, 0) << "backward Euler halves where it too puts energy in";
  EXPECT_LE(guarded.highest, guarded.start * (1 + 200 * kGuardTolerance));
}

TEST(GuardedBdf2, OnlyTheKeptAttemptsSolvesCountAsFailed) {
  IntegratorSettings settings = bdf2_alpha(0.02, true);
  settings.cg_max_iterations = 0;
  const StepStatistics st = spin(settings).stats;
  EXPECT_GT(st.cg_solves, st.guard_parts);
  EXPECT_GT(st.cg_failures, 0);
  EXPECT_LE(st.cg_failures, st.guard_parts);
}

TEST(GuardedBdf2, SameResultsAsThePlainStepWhereTheGuardNeverActs) {
  // On a linear system BDF-2 at alpha > 1/2 only dissipates: the guard never acts.
  StepStatistics plain_stats, guarded_stats;
  const State plain = linear_chain_end(bdf2_alpha(0.05, false), plain_stats);
  const State guarded = linear_chain_end(bdf2_alpha(0.05, true), guarded_stats);
  EXPECT_EQ(guarded_stats.guard_redone_steps + guarded_stats.guard_raised_steps, 0);
  expect_same_bits(plain, guarded);
}

TEST(GuardedBdf2, TheSwingCreatesNoEnergyWithTheGuardAndTheBalanceCloses) {
  // On the 21x21 swing the plain BDF-2 at alpha = 1/sqrt(3) stays bounded but creates energy
  // (its numerical dissipation goes below zero by far more than the guard allows); the guarded
  // one keeps every accepted step within the tolerance.
  Scene scene = load_scene(std::string(WEFT_SOURCE_DIR) + "/scenes/swing-21x21.json");
  scene.duration = 1.0;
  double lowest[2] = {0, 0}, bound = 0;
  for (bool guard : {false, true}) {
    set_method(scene, guard ? "bdf2-alpha-guarded" : "bdf2-alpha", std::nullopt, "test");
    Simulation sim(scene);
    const RunResult r = run_simulation(sim);
    ASSERT_EQ(r.status, "ok") << r.message;
    double scale = sim.energy_scale();
    for (const EnergyRow& e : r.energy) scale = std::max(scale, e.kinetic + e.elastic);
    for (const EnergyRow& e : r.energy) {
      lowest[guard] = std::min(lowest[guard], e.numerical_dissipated);
      EXPECT_GE(e.viscous_dissipated, 0.0);
    }
    if (guard) {
      EXPECT_GT(r.steps.guard_redone_steps, 0);
      bound = static_cast<double>(r.steps.steps) * kGuardTolerance * scale;
    }
  }
  EXPECT_GE(lowest[1], -bound);
  EXPECT_LT(lowest[0], -10 * bound) << "the plain step must create energy here for the test to mean anything";
}
