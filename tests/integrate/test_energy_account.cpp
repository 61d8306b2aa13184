// An energy account kept apart from the integrators' own (docs/method.md 6): the viscous work is
// integrated here from the viscous forces each step applied, and checked against the
// dissipation the integrator reports and, where the method must close the balance, against
// the change in mechanical energy. The systems are linear (zero-rest-length springs), so the
// semi-implicit step is exactly the alpha family's formula: M dv = dt f(x + alpha dx, v + alpha dv).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;

namespace {

// Three masses in a chain of zero-rest-length springs with viscosity, the first tied to the
// origin; a constant gravity, so that its potential is part of the balance.
const std::vector<Spring> kChain = {{0, -1, 30.0, 0.0, 0.4}, {0, 1, 20.0, 0.0, 0.7}, {1, 2, 45.0, 0.0, 0.3}};
const Vec3 kGravity(0, -9.81, 0);

VecX chain_mass() {
  VecX m(3);
  m << 0.2, 0.35, 0.15;
  return m;
}

State chain_start() {
  State s;
  s.x = VecX(9);
  s.x << 0.3, -0.2, 0.1, 0.9, -0.5, -0.2, 1.4, -0.1, 0.4;
  s.v = VecX(9);
  s.v << 0.5, 1.2, -0.3, -0.8, 0.2, 0.6, 0.1, -1.1, 0.9;
  return s;
}

Vec3 at(const VecX& q, int i) { return q.segment<3>(3 * i); }

/// Kinetic + spring + gravitational energy of the chain, from the definitions.
double mechanical_energy(const State& s) {
  const VecX m = chain_mass();
  double e = 0;
  for (int i = 0; i < 3; ++i) e += 0.5 * m[i] * at(s.v, i).squaredNorm() - m[i] * kGravity.dot(at(s.x, i));
  for (const Spring& sp : kChain) {
    const Vec3 d = at(s.x, sp.a) - (sp.b >= 0 ? at(s.x, sp.b) : sp.anchor);
    e += 0.5 * sp.stiffness * d.squaredNorm();
  }
  return e;
}

/// Work done against the viscous forces -l (v_a - v_b) evaluated at velocity `va` while the
/// nodes move by `dx`: sum over springs of l (dx_a - dx_b) . (va_a - va_b).
double viscous_work(const VecX& dx, const VecX& va) {
  double w = 0;
  for (const Spring& sp : kChain) {
    const Vec3 d = at(dx, sp.a) - (sp.b >= 0 ? at(dx, sp.b) : Vec3::Zero());
    const Vec3 u = at(va, sp.a) - (sp.b >= 0 ? at(va, sp.b) : Vec3::Zero());
    w += sp.viscosity * d.dot(u);
  }
  return w;
}

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

IntegratorSettings tight(Method method, double alpha, double dt) {
  IntegratorSettings st;
  st.method = method;
  st.alpha = alpha;
  st.dt = dt;
  st.cg_tolerance = 1e-14;
  st.cg_max_iterations = 200;
  st.ssor_single_precision = false;
  st.preconditioner = Preconditioner::kBlockJacobi;
  return st;
}

}  // namespace

TEST(EnergyAccount, AlphaFamilyStepsAccountTheWorkOfTheViscousForcesTheyApplied) {
  // The alpha-family step applies f at v + alpha dv over the displacement dx, so the work
  // against the viscous forces over the step is dx . L (v + alpha dv); forward Euler's is
  // alpha = 0. Implicit Midpoint (alpha = 1/2) evaluates f at the mean of the two states, so
  // on a linear system its balance closes: the change of mechanical energy plus that work is
  // zero, up to the linear solve's tolerance.
  struct Case {
    Method method;
    double alpha;
    const char* name;
  };
  for (const Case& c : {Case{Method::kForwardEuler, 0.0, "forward Euler"}, Case{Method::kAlphaFamily, 0.5, "Implicit Midpoint"},
                        Case{Method::kAlphaFamily, 1.0, "backward Euler"}, Case{Method::kAlphaFamily, 0.7, "alpha 0.7"}}) {
    SpringSystem sys(chain_mass(), kChain, kGravity);
    const double dt = 0.01;
    Integrator integ(sys, tight(c.method, c.alpha, dt));
    State s = chain_start();
    StepStatistics stats;
    const double e0 = mechanical_energy(s);
    double account = 0, worst_closure = 0;
    for (int k = 0; k < 100; ++k) {
      const State before = s;
      integ.step(s, dt, stats);
      const VecX dx = s.x - before.x, va = before.v + c.alpha * (s.v - before.v);
      const double work = viscous_work(dx, va);
      account += work;
      worst_closure = std::max(worst_closure, std::abs(mechanical_energy(s) - mechanical_energy(before) + work));
    }
    ASSERT_EQ(stats.cg_failures, 0) << c.name;
    ASSERT_GT(account, 0.05 * e0) << c.name << ": the viscous forces should matter here";
    EXPECT_NEAR(s.viscous_dissipated, account, 1e-9 * account) << c.name;
    if (c.alpha == 0.5) EXPECT_LT(worst_closure, 1e-9 * account) << c.name;
  }
}

namespace {

/// |E(T) + D(T) - E(0)| of a run of `method` over 1 s with step dt: what the account misses.
double closure_gap(Method method, double dt) {
  SpringSystem sys(chain_mass(), kChain, kGravity);
  Integrator integ(sys, tight(method, 0.0, dt));
  State s = chain_start();
  StepStatistics stats;
  const double e0 = mechanical_energy(s);
  integ.advance(s, 1.0, stats);
  return std::abs(mechanical_energy(s) + s.viscous_dissipated - e0);
}

}  // namespace

TEST(EnergyAccount, Rk4BalanceClosesAtTheMethodsOrder) {
  // RK4 integrates the dissipation with the same stage weights as the state (the augmented
  // system x' = v, v' = a, D' = -P), so the balance closes to the method's global order: four.
  // Halving the step must shrink the gap by about 16 once the step is small against the
  // fastest period (here about 0.3 s); 8 leaves room for the higher-order terms.
  const double coarse = closure_gap(Method::kRk4, 0.0025), fine = closure_gap(Method::kRk4, 0.00125);
  RecordProperty("gap_coarse", sci(coarse));
  RecordProperty("gap_fine", sci(fine));
  EXPECT_GT(coarse / fine, 8.0) << coarse << " then " << fine;
}

namespace {

struct Rk45Step {
  State state;
  double error_estimate = 0;  ///< the step's error norm times the tolerance (see below)
};

/// One accepted RK45 step of size h from `start` on `sys`. The integrator does not expose
/// its error norm, but its step-size controller does: after an accepted step the next step
/// is h * 0.9 err^(-1/5) when that lies within [0.2 h, 5 h]. The norm scales every component
/// by tol (1 + |x|), so err * tol does not depend on the tolerance: the tolerance is lowered
/// by tens until the controller is off its bounds.
Rk45Step rk45_step(System& sys, const State& start, double h) {
  for (double tol = 1e-1; tol > 1e-15; tol /= 10) {
    IntegratorSettings st;
    st.method = Method::kRk45;
    st.dt = 10 * h;  // so that the next step is not capped by dt
    st.error_tolerance = tol;
    Integrator integ(sys, st);
    State s = start;
    s.rk45_step = 0;
    StepStatistics stats;
    integ.advance(s, start.t + h, stats);
    if (stats.rejected_steps != 0 || stats.steps != 1) continue;
    const double factor = s.rk45_step / h;
    if (!(factor > 0.2 * 1.0001 && factor < 5.0 * 0.9999)) continue;
    return {s, std::pow(factor / 0.9, -5.0) * tol};
  }
  ADD_FAILURE() << "no tolerance put RK45's step controller within its bounds at h = " << h;
  return {};
}

}  // namespace

TEST(Rk45ErrorEstimate, ScalesAsTheFourthOrderSolutionsLocalErrorAndBoundsTheTrueError) {
  // Undamped oscillator x'' = -x from x = 1, v = 0: the exact solution is (cos t, -sin t).
  // Dormand-Prince estimates the local error of its embedded fourth-order solution, which is
  // O(h^5): halving h divides the estimate by about 32. The fifth-order solution it keeps is
  // more accurate still, so its true local error lies below the estimate.
  SpringSystem sys = weft::test::one_spring(1.0, 1.0, 0.0);
  State start;
  start.x = Vec3(1, 0, 0);
  start.v = Vec3(0, 0, 0);
  double previous = 0;
  for (double h : {0.4, 0.2, 0.1}) {
    const Rk45Step r = rk45_step(sys, start, h);
    ASSERT_GT(r.error_estimate, 0) << "h = " << h;
    // The same norm of the true error: components scaled by 1 + max(|start|, |end|).
    double sum = 0;
    const Vec3 xe(std::cos(h), 0, 0), ve(-std::sin(h), 0, 0);
    for (int i = 0; i < 3; ++i) {
      const double ex = (r.state.x[i] - xe[i]) / (1 + std::max(std::abs(start.x[i]), std::abs(r.state.x[i])));
      const double ev = (r.state.v[i] - ve[i]) / (1 + std::max(std::abs(start.v[i]), std::abs(r.state.v[i])));
      sum += ex * ex + ev * ev;
    }
    const double true_error = std::sqrt(sum / 6.0);
    EXPECT_LT(true_error, r.error_estimate) << "h = " << h;
    if (previous > 0) {
      const double order = std::log2(previous / r.error_estimate);
      RecordProperty("order_at_h_" + sci(h), sci(order));
      EXPECT_GT(order, 4.5) << "h = " << h;
      EXPECT_LT(order, 5.5) << "h = " << h;
    }
    previous = r.error_estimate;
  }
}

TEST(EnergyAccount, Rk45StepClosesTheBalanceToItsFifthOrder) {
  // RK45 accounts the viscous work with the weights of the solution it keeps (fifth order),
  // so over one step the balance of a damped oscillator closes to O(h^6): halving h divides
  // the gap by about 64. Weights of the embedded fourth-order solution would leave O(h^5).
  SpringSystem sys = weft::test::one_spring(1.0, 1.0, 0.5);
  State start;
  start.x = Vec3(1, 0, 0);
  start.v = Vec3(0.3, 0, 0);
  const auto energy = [](const State& s) { return 0.5 * s.v.squaredNorm() + 0.5 * s.x.squaredNorm(); };
  std::vector<double> gaps;
  for (double h : {0.2, 0.1}) {
    const Rk45Step r = rk45_step(sys, start, h);
    ASSERT_GT(r.state.viscous_dissipated, 0) << "h = " << h;
    gaps.push_back(std::abs(energy(r.state) + r.state.viscous_dissipated - energy(start)));
  }
  RecordProperty("gaps", sci(gaps[0]) + " " + sci(gaps[1]));
  EXPECT_GT(std::log2(gaps[0] / gaps[1]), 5.5) << gaps[0] << " then " << gaps[1];
}
