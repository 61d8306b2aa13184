// An unguarded semi-implicit step that holds contacts and whose solve puts energy in
// (kSolveGainLimit) is taken again as two halves; without held contacts, or without an energy
// scale, the step is the method's own.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "integrate/integrator.hpp"
#include "support/spinning_spring.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;
using weft::test::mechanical_energy;
using weft::test::spinning_spring_state;

namespace {

// Holds node 1, at rest on a floor through it, where it is: a contact that does no work.
class RestingNode : public ContactHandler {
 public:
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>& out) override {
    NodeContact c;
    c.node = 1;
    c.normal = Vec3::UnitY();
    out.push_back(c);
  }
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX&, VecX&, double, double, ContactReport&) override {}
};

struct SpinRun {
  double start = 0, highest = 0;
  StepStatistics stats;
};

// The stiff spinning spring of the midpoint tests (1 kg, 10^6 N/m, 5 m/s) at 40 ms steps, a
// quarter turn in four: the linearised step stretches the spring it turns, by up to fifteen
// times the energy it had. Beside it, a node held at rest.
SpinRun spin(double alpha, bool held, double energy_scale) {
  const double k = 1e6;
  SpringSystem sys(VecX::Constant(2, 1.0), {Spring{0, -1, k, 1.0, 0.0}});
  const State spinning = spinning_spring_state(k, 5.0);
  State s;
  s.x = VecX(6);
  s.x << spinning.x, Vec3(5, 0, 0);
  s.v = VecX(6);
  s.v << spinning.v, Vec3::Zero();
  IntegratorSettings settings;
  settings.alpha = alpha;
  settings.dt = 0.04;
  settings.cg_tolerance = 1e-12;
  Integrator in(sys, settings);
  if (energy_scale > 0) in.set_energy_scale(energy_scale);
  RestingNode floor;
  if (held) in.add_contact_handler(&floor);
  SpinRun r;
  r.start = r.highest = mechanical_energy(sys, s);
  for (int n = 0; n < 100; ++n) {
    in.step(s, settings.dt, r.stats);
    r.highest = std::max(r.highest, mechanical_energy(sys, s));
  }
  return r;
}

}  // namespace

TEST(SolveGain, AStepHoldingContactsWhoseSolvePutsEnergyInIsTakenAgainAsHalves) {
  const double scale = 0.01 * spin(0.5, false, 0).start;  // 1% of the spring's energy
  const SpinRun plain = spin(0.5, false, scale), unscaled = spin(0.5, true, 0), halved = spin(0.5, true, scale);
  // Without held contacts, or without an energy scale, the plain midpoint's own steps, which
  // blow up.
  EXPECT_GT(plain.highest, 10 * plain.start);
  EXPECT_EQ(plain.stats.halved_steps, 0);
  EXPECT_GT(unscaled.highest, 10 * unscaled.start);
  EXPECT_EQ(unscaled.stats.halved_steps, 0);
  // Holding a contact, the steps that overshoot are taken as halves: 20 ms steps, whose gains
  // stay below the limit and, over many more steps than these, below the start's energy again
  // (GuardedMidpoint.StiffSpinningSpringGainsEnergyOnlyWithoutTheGuard's plain run).
  EXPECT_GT(halved.stats.halved_steps, 0);
  EXPECT_LT(halved.highest, 2 * halved.start);
}
