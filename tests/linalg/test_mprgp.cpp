#include <gtest/gtest.h>

#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "linalg/mprgp.hpp"

namespace weft {
namespace {

// A chain of nodes joined to their next and second-next neighbours by springs along random
// directions, over a lumped mass: symmetric positive definite, as a cloth step's matrix.
struct SpringProblem {
  BlockPattern pattern;
  BlockMatrix A;
  VecX b;
  SpringProblem(int n, unsigned seed, double stiffness = 50.0) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i + 1 < n; ++i) pairs.push_back({i, i + 1});
    for (int i = 0; i + 2 < n; ++i) pairs.push_back({i, i + 2});
    pattern = BlockPattern(n, pairs);
    A.reset(pattern);
    for (int i = 0; i < n; ++i) A.block[pattern.diagonal_slot(i)] += (1.0 + 0.5 * u(rng)) * Mat3::Identity();
    for (const auto& [i, j] : pairs) {
      const Vec3 d = Vec3(u(rng), u(rng), u(rng)).normalized();
      const Mat3 k = stiffness * (1.5 + u(rng)) * d * d.transpose();
      A.block[pattern.diagonal_slot(i)] += k;
      A.block[pattern.diagonal_slot(j)] += k;
      A.block[pattern.slot(i, j)] -= k;
      A.block[pattern.slot(j, i)] -= k;
    }
    b.resize(3 * n);
    for (int k = 0; k < 3 * n; ++k) b[k] = u(rng);
  }
};

Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

// The conditions of the problem's minimum (sufficient: the problem is strictly convex): x is
// feasible; held nodes kept their values; the residual r = b - A x vanishes on every free
// direction, and at a bounded node equals -sum mu_k n_k with mu_k >= 0 over its active bounds
// (pressing the node onto them, never pulling it off), the active ones met exactly.
void expect_minimum(const SpringProblem& p, const std::vector<char>& held, const VecX& held_values,
                    const std::vector<NodeBound>& bounds, const VecX& x, const std::vector<char>& active) {
  const int n = p.pattern.num_nodes();
  VecX r;
  p.A.multiply(x, r);
  r = p.b - r;
  const double scale = p.b.norm();
  std::vector<Vec3> left(n);
  for (int i = 0; i < n; ++i) left[i] = r.segment<3>(3 * i);
  ASSERT_EQ(active.size(), bounds.size());
  for (size_t k = 0; k < bounds.size(); ++k) {
    const NodeBound& c = bounds[k];
    const double gap = c.normal.dot(x.segment<3>(3 * c.node)) - c.lower;
    EXPECT_GE(gap, -1e-9) << "bound " << k << " crossed";
    if (active[k]) {
      EXPECT_NEAR(gap, 0.0, 1e-9) << "active bound " << k << " not met";
      const double along = c.normal.dot(r.segment<3>(3 * c.node));
      EXPECT_LE(along, 1e-5 * scale) << "bound " << k << " pulls";
      left[c.node] -= along * c.normal;
    }
  }
  for (int i = 0; i < n; ++i) {
    if (held[i]) {
      EXPECT_EQ(x.segment<3>(3 * i), held_values.segment<3>(3 * i)) << "held node " << i << " moved";
      continue;
    }
    EXPECT_LT(left[i].norm(), 1e-5 * scale) << "node " << i << " has a free residual";
  }
}

TEST(BoundedSolve, WithoutBoundsItIsTheLinearSolve) {
  const SpringProblem p(40, 1);
  VecX x = VecX::Zero(p.b.size());
  BoundedSolveWorkspace ws;
  std::vector<char> active;
  const std::vector<char> held(40, 0);
  const BoundedSolveResult r = solve_bounded(p.A, p.b, held, {}, BoundedSolveSettings{1e-10, 2000}, x, ws, active);
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.expansions, 0);
  EXPECT_EQ(r.proportionings, 0);
  const VecX exact = p.A.to_dense().ldlt().solve(p.b);
  EXPECT_LT((x - exact).norm(), 1e-7 * exact.norm());
}

TEST(BoundedSolve, MeetsTheConditionsOfTheMinimumWithOneAndTwoBoundsPerNodeAndHeldNodes) {
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const int n = 30;
    const SpringProblem p(n, seed);
    std::mt19937 rng(100 + seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<NodeBound> bounds;
    std::vector<char> held(n, 0);
    VecX x = VecX::Zero(3 * n);
    for (int i = 0; i < n; ++i) {
      const int kind = i % 5;
      if (kind == 1 || kind == 3) {
        // A bound that cuts through the unconstrained answer's neighbourhood.
        bounds.push_back({i, random_unit(rng), 0.3 * u(rng)});
      } else if (kind == 2) {
        const Vec3 a = random_unit(rng);
        const Vec3 c = a.cross(random_unit(rng)).normalized();
        bounds.push_back({i, a, 0.3 * u(rng)});
        bounds.push_back({i, c, 0.3 * u(rng)});
      } else if (kind == 4 && i % 10 == 4) {
        held[i] = 1;
        x.segment<3>(3 * i) = Vec3(u(rng), u(rng), u(rng));
      }
    }
    const VecX held_values = x;
    BoundedSolveWorkspace ws;
    std::vector<char> active;
    const BoundedSolveResult r = solve_bounded(p.A, p.b, held, bounds, BoundedSolveSettings{1e-10, 5000}, x, ws, active);
    ASSERT_TRUE(r.converged) << "seed " << seed << ": " << r.relative_residual << " after " << r.iterations << " products, " << r.expansions << " expansions, " << r.proportionings << " proportionings";
    expect_minimum(p, held, held_values, bounds, x, active);
  }
}

// From a guess that sits on every bound, with a load pulling half the nodes off them: the
// solve must free bounds (proportioning) as well as meet new ones (expansion).
TEST(BoundedSolve, FreesBoundsThatPullAndMeetsBoundsItCrosses) {
  const int n = 24;
  SpringProblem p(n, 7);
  std::vector<NodeBound> bounds;
  for (int i = 0; i < n; ++i) {
    bounds.push_back({i, Vec3::UnitY(), 0.0});
    p.b.segment<3>(3 * i) = Vec3(0.1, i % 2 ? 2.0 : -2.0, 0.0);
  }
  VecX x = VecX::Zero(3 * n);
  x(3 * 3 + 1) = 0.5;  // one node starts above its bound
  const std::vector<char> held(n, 0);
  BoundedSolveWorkspace ws;
  std::vector<char> active;
  const BoundedSolveResult r = solve_bounded(p.A, p.b, held, bounds, BoundedSolveSettings{1e-10, 5000}, x, ws, active);
  ASSERT_TRUE(r.converged);
  EXPECT_GT(r.proportionings + r.expansions, 0);
  expect_minimum(p, held, x, bounds, x, active);
  int on = 0;
  for (char a : active) on += a;
  EXPECT_GT(on, 0);
  EXPECT_LT(on, n);
}

// A load that pushes every node through its bound: the first CG step crosses them all. The
// projected CG step meets them together; the projected gradient step alone meets a few at a
// time, restarting CG after each. Both must reach the minimum.
TEST(BoundedSolve, TheProjectedCgStepMeetsTheBoundsACgStepCrossesTogether) {
  const int n = 60;
  SpringProblem p(n, 11);
  std::vector<NodeBound> bounds;
  for (int i = 0; i < n; ++i) {
    bounds.push_back({i, Vec3::UnitY(), 0.0});
    p.b.segment<3>(3 * i) = Vec3(0.2, -3.0 - 0.05 * i, 0.1);
  }
  const std::vector<char> held(n, 0);
  BoundedSolveResult with, without;
  for (bool projected : {true, false}) {
    BoundedSolveSettings settings{1e-10, 5000};
    settings.projected_cg_step = projected;
    VecX x = VecX::Constant(3 * n, 0.5);
    BoundedSolveWorkspace ws;
    std::vector<char> active;
    const BoundedSolveResult r = solve_bounded(p.A, p.b, held, bounds, settings, x, ws, active);
    ASSERT_TRUE(r.converged) << "projected " << projected;
    expect_minimum(p, held, x, bounds, x, active);
    (projected ? with : without) = r;
  }
  EXPECT_LT(with.expansions, without.expansions);
}

TEST(BoundedSolve, RefusesThreeBoundsOnOneNode) {
  const SpringProblem p(4, 3);
  VecX x = VecX::Zero(12);
  BoundedSolveWorkspace ws;
  std::vector<char> active;
  const std::vector<NodeBound> bounds{{2, Vec3::UnitX(), 0}, {2, Vec3::UnitY(), 0}, {2, Vec3::UnitZ(), 0}};
  try {
    solve_bounded(p.A, p.b, std::vector<char>(4, 0), bounds, BoundedSolveSettings{}, x, ws, active);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "solve_bounded: more than two bounds on node 2");
  }
}

}  // namespace
}  // namespace weft
