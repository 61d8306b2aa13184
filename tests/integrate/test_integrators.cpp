// Integrators on spring systems: the one-spring step matrix against the paper's H
// (docs/method.md 3), measured global convergence orders (docs/method.md 2), and energy behaviour.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>

#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::one_spring;

namespace {

IntegratorSettings settings_for(Method method, double alpha, double dt) {
  IntegratorSettings s;
  s.method = method;
  s.alpha = alpha;
  s.dt = dt;
  s.cg_tolerance = 1e-14;
  s.cg_max_iterations = 100;
  s.error_tolerance = 1e-12;
  return s;
}

State initial(double p0, double v0) {
  State s;
  s.x = Vec3(p0, 0, 0);
  s.v = Vec3(v0, 0, 0);
  return s;
}

}  // namespace

TEST(OneSpring, AlphaFamilyStepMatrixEqualsPapersH) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const double alpha = U(rng), kappa = 10 * U(rng) + 1e-3, lambda = 3 * U(rng);
    const double m = 0.5 + U(rng), dt = 0.01 + 0.05 * U(rng);
    const double k = kappa * m / (dt * dt), l = lambda * m / dt;
    auto sys = one_spring(m, k, l);
    // Columns of the step map on q = [p, p' dt], from unit initial states.
    Eigen::Matrix2d Hnum;
    for (int c = 0; c < 2; ++c) {
      State s = initial(c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 / dt : 0.0);
      Integrator integ(sys, settings_for(Method::kAlphaFamily, alpha, dt));
      StepStatistics st;
      integ.step(s, dt, st);
      Hnum(0, c) = s.x[0];
      Hnum(1, c) = s.v[0] * dt;
    }
    const double D = 1 + lambda * alpha + kappa * alpha * alpha;
    Eigen::Matrix2d H;
    H << 1 - kappa * alpha / D, 1 / D, -kappa / D, 1 - (lambda + kappa * alpha) / D;
    EXPECT_LT((Hnum - H).norm(), 1e-10 * H.norm()) << "alpha " << alpha << " kappa " << kappa << " lambda " << lambda;
  }
}

namespace {
// Error at time T of the damped spring m p'' = -k p - l p' from p = 1, p' = 0.
double global_error(Method method, double alpha, double dt) {
  const double m = 1, k = 4 * M_PI * M_PI, l = 0.3, T = 1.0;
  auto sys = one_spring(m, k, l);
  State s = initial(1.0, 0.0);
  Integrator integ(sys, settings_for(method, alpha, dt));
  StepStatistics st;
  integ.advance(s, T, st);
  const double w0 = std::sqrt(k / m), z = l / (2 * std::sqrt(k * m)), wd = w0 * std::sqrt(1 - z * z);
  const double exact = std::exp(-z * w0 * T) * (std::cos(wd * T) + z * w0 / wd * std::sin(wd * T));
  const double exact_v = -std::exp(-z * w0 * T) * (w0 * w0 / wd) * std::sin(wd * T);
  return std::hypot(s.x[0] - exact, (s.v[0] - exact_v) / w0);
}

double measured_order(Method method, double alpha, double dt0) {
  // Least-squares slope of log error against log dt over four halvings.
  std::vector<double> lx, ly;
  for (int h = 0; h < 4; ++h) {
    const double dt = dt0 / (1 << h);
    lx.push_back(std::log(dt));
    ly.push_back(std::log(global_error(method, alpha, dt)));
  }
  const double mx = std::accumulate(lx.begin(), lx.end(), 0.0) / lx.size();
  const double my = std::accumulate(ly.begin(), ly.end(), 0.0) / ly.size();
  double num = 0, den = 0;
  for (size_t i = 0; i < lx.size(); ++i) {
    num += (lx[i] - mx) * (ly[i] - my);
    den += (lx[i] - mx) * (lx[i] - mx);
  }
  return num / den;
}
}  // namespace

TEST(ConvergenceOrder, MatchesTheory) {
  struct Case {
    const char* name;
    Method method;
    double alpha, dt0, order;
  };
  const Case cases[] = {
      {"forward Euler", Method::kForwardEuler, 0.0, 1.0 / 1000, 1},
      {"backward Euler", Method::kAlphaFamily, 1.0, 1.0 / 1000, 1},
      {"Implicit Midpoint", Method::kAlphaFamily, 0.5, 1.0 / 100, 2},
      {"BDF-2", Method::kBdf2, 1.0, 1.0 / 100, 2},
      {"BDF-2 alpha = 1/sqrt(3)", Method::kBdf2, 1.0 / std::sqrt(3.0), 1.0 / 100, 2},
      {"RK4", Method::kRk4, 0.0, 1.0 / 20, 4},
  };
  for (const auto& c : cases) {
    const double p = measured_order(c.method, c.alpha, c.dt0);
    RecordProperty(c.name, std::to_string(p));
    EXPECT_NEAR(p, c.order, 0.15) << c.name;
  }
}


TEST(Energy, ImplicitMidpointKeepsEnergyOfUndampedLinearSystemBackwardEulerLosesIt) {
  // A chain of zero-rest-length springs (linear) with random masses, undamped.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0.5, 1.5);
  const int n = 8;
  VecX mass(n);
  std::vector<weft::test::Spring> springs;
  for (int i = 0; i < n; ++i) {
    mass[i] = U(rng);
    springs.push_back({i, i + 1 < n ? i + 1 : -1, 50 * U(rng), 0.0, 0.0});
  }
  auto energy = [&](const State& s) {
    weft::test::SpringSystem sys(mass, springs);
    Evaluation e;
    sys.prepare(e);
    sys.evaluate(s.x, s.v, false, e);
    double kin = 0;
    for (int i = 0; i < n; ++i) kin += 0.5 * mass[i] * node(s.v, i).squaredNorm();
    return kin + e.elastic_energy;
  };
  State s0;
  s0.x = VecX::Random(3 * n);
  s0.v = VecX::Random(3 * n);
  const double e0 = energy(s0);
  for (double alpha : {0.5, 1.0}) {
    weft::test::SpringSystem sys(mass, springs);
    auto st = settings_for(Method::kAlphaFamily, alpha, 0.05);  // kappa up to ~0.4 per mass
    st.cg_tolerance = 1e-12;
    Integrator integ(sys, st);
    State s = s0;
    StepStatistics stats;
    integ.advance(s, 10.0, stats);
    const double e1 = energy(s);
    if (alpha == 0.5) {
      EXPECT_NEAR(e1, e0, 1e-8 * e0) << "Implicit Midpoint";
    } else {
      EXPECT_LT(e1, 0.5 * e0) << "backward Euler should dissipate";
    }
  }
}

TEST(WarmStart, HistorySpanningTheRightHandSidesMakesTheSolvesNearlyFree) {
  // Two nodes on zero-rest-length springs (linear, undamped): the step matrix is the same
  // every step, and the right-hand side, -dt K (x + dt v / 2), follows the step map of the
  // two nodes' positions and velocities, the same 4x4 map in each direction, so any four
  // consecutive right-hand sides span all later ones (Cayley-Hamilton). With four pairs kept
  // the guess is the solution itself, up to the rounding of the recorded solutions; without
  // history (the previous dv as the guess) every solve iterates. How the rounding falls
  // differs between instruction sets (a recorded solution a few ulps off can leave a guess
  // just above the tolerance and cost an iteration or two), so the test asserts what holds on
  // any IEEE machine: with the history most solves take no iteration and all of them together
  // take a small fraction of the cold solves' iterations.
  VecX mass(2);
  mass << 1.0, 1.3;
  const std::vector<weft::test::Spring> springs = {{0, 1, 40.0, 0.0, 0.0}, {1, -1, 25.0, 0.0, 0.0}};
  State s0;
  s0.x = VecX(6);
  s0.x << 0.3, -0.2, 0.5, 1.1, 0.4, -0.7;
  s0.v = VecX(6);
  s0.v << 0.2, 0.9, -0.4, -0.5, 0.1, 0.3;
  constexpr int kSteps = 20;
  long total[2] = {0, 0};
  int free_solves[2] = {0, 0};
  const int histories[2] = {4, 0};
  for (int h = 0; h < 2; ++h) {
    weft::test::SpringSystem sys(mass, springs);
    auto st = settings_for(Method::kAlphaFamily, 0.5, 0.05);
    st.cg_tolerance = 1e-8;
    st.warm_start_history = histories[h];
    st.ssor_single_precision = false;
    Integrator integ(sys, st);
    State s = s0;
    StepStatistics stats;
    for (int k = 0; k < 6; ++k) integ.step(s, 0.05, stats);
    for (int k = 0; k < kSteps; ++k) {
      const long before = stats.cg_iterations;
      integ.step(s, 0.05, stats);
      const long iterations = stats.cg_iterations - before;
      total[h] += iterations;
      if (iterations == 0) ++free_solves[h];
    }
    EXPECT_EQ(stats.cg_failures, 0) << "history " << histories[h];
  }
  EXPECT_EQ(free_solves[1], 0) << "without history every solve should iterate";
  EXPECT_GE(total[1], kSteps);
  EXPECT_GE(free_solves[0], kSteps / 2) << "with four pairs kept most solves should need no iteration";
  EXPECT_LE(4 * total[0], total[1]) << "history: " << total[0] << " iterations, none: " << total[1];
}
