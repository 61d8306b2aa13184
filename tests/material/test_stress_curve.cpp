// Properties of the stress-strain curves: interpolation, monotonicity, C1 continuity,
// derivatives (finite differences), exact energy, extrapolation, mirroring, branch averaging.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "weft/error.hpp"
#include "weft/material.hpp"

namespace weft {
namespace {

// A stiffening tensile table on uneven strain steps (N/m against Green strain).
StressCurve stiffening() {
  return StressCurve::tabulated({0.0, 0.005, 0.01, 0.02, 0.03, 0.045, 0.06, 0.08},
                                {0.0, 3.0, 7.5, 20.0, 45.0, 110.0, 230.0, 520.0});
}

// Non-monotone data with a flat part and a local maximum.
StressCurve wiggly() {
  return StressCurve::tabulated({-0.02, 0.0, 0.01, 0.03, 0.04, 0.05, 0.07},
                                {-5.0, 0.0, 4.0, 4.0, 9.0, 6.0, 30.0});
}

double fd_stress(const StressCurve& c, double e, double h = 1e-6) {
  return (c.stress(e + h) - c.stress(e - h)) / (2 * h);
}

double fd_energy(const StressCurve& c, double e, double h = 1e-6) {
  return (c.energy(e + h) - c.energy(e - h)) / (2 * h);
}

std::vector<double> samples(double lo, double hi, int n) {
  std::vector<double> out;
  for (int i = 0; i <= n; ++i) out.push_back(lo + (hi - lo) * i / n);
  return out;
}

TEST(SplineCurve, PassesThroughItsPoints) {
  for (const StressCurve& c : {stiffening(), wiggly()}) {
    for (std::size_t i = 0; i < c.strain_points().size(); ++i) {
      EXPECT_DOUBLE_EQ(c.stress(c.strain_points()[i]), c.stress_points()[i]) << i;
    }
  }
}

TEST(SplineCurve, MonotoneWhereTheDataAre) {
  const StressCurve c = wiggly();
  const auto& x = c.strain_points();
  const auto& y = c.stress_points();
  for (std::size_t k = 0; k + 1 < x.size(); ++k) {
    const double sign = (y[k + 1] > y[k]) - (y[k + 1] < y[k]);
    double prev = c.stress(x[k]);
    for (double e : samples(x[k], x[k + 1], 400)) {
      const double s = c.stress(e);
      if (sign == 0) {
        EXPECT_NEAR(s, y[k], 1e-12) << "flat segment " << k << " at " << e;
      } else {
        EXPECT_GE(sign * (s - prev), -1e-12) << "segment " << k << " at " << e;
        // No overshoot: stays between the segment's end values.
        EXPECT_GE(s, std::min(y[k], y[k + 1]) - 1e-12);
        EXPECT_LE(s, std::max(y[k], y[k + 1]) + 1e-12);
      }
      prev = s;
    }
  }
  const StressCurve t = stiffening();
  for (double e : samples(-0.01, 0.1, 2000)) EXPECT_GT(t.tangent(e), 0.0) << e;
}

TEST(SplineCurve, ContinuousDerivativeAtKnots) {
  for (const StressCurve& c : {stiffening(), wiggly()}) {
    for (double x : c.strain_points()) {
      // Second-order one-sided differences, each using one segment only.
      const double h = 1e-6;
      const double left = (3 * c.stress(x) - 4 * c.stress(x - h) + c.stress(x - 2 * h)) / (2 * h);
      const double right = (-3 * c.stress(x) + 4 * c.stress(x + h) - c.stress(x + 2 * h)) / (2 * h);
      const double scale = 1.0 + std::abs(c.tangent(x));
      EXPECT_NEAR(left, right, 1e-4 * scale) << "knot " << x;
      EXPECT_NEAR(c.tangent(x - 1e-12), c.tangent(x + 1e-12), 1e-6 * scale) << "knot " << x;
    }
  }
}

TEST(SplineCurve, TangentIsDerivativeOfStress) {
  for (const StressCurve& c : {stiffening(), wiggly()}) {
    for (double e : samples(-0.04, 0.12, 157)) {
      EXPECT_NEAR(c.tangent(e), fd_stress(c, e), 1e-4 * (1.0 + std::abs(c.tangent(e)))) << e;
    }
  }
}

TEST(SplineCurve, EnergyIsIntegralOfStress) {
  for (const StressCurve& c : {stiffening(), wiggly()}) {
    EXPECT_EQ(c.energy(0.0), 0.0);
    for (double e : samples(-0.04, 0.12, 157)) {
      EXPECT_NEAR(fd_energy(c, e), c.stress(e), 1e-5 * (1.0 + std::abs(c.stress(e)))) << e;
    }
  }
}

TEST(SplineCurve, EnergyReferenceIsStrainZeroWhenZeroIsNotAKnot) {
  // Table entirely at positive strain: energy still vanishes at 0 and grows as the integral.
  const StressCurve c = StressCurve::tabulated({0.01, 0.02, 0.04}, {5.0, 12.0, 40.0});
  EXPECT_EQ(c.energy(0.0), 0.0);
  // Between 0 and the first knot the curve is the straight extrapolation: trapezoid rule exact.
  const double e = 0.01;
  EXPECT_NEAR(c.energy(e), 0.5 * (c.stress(0.0) + c.stress(e)) * e, 1e-12);
  // Independent midpoint-rule integral across the knots.
  const int n = 20000;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += c.stress((i + 0.5) * 0.05 / n) * 0.05 / n;
  EXPECT_NEAR(c.energy(0.05), sum, 1e-7);
}

TEST(SplineCurve, LinearPastTheEnds) {
  const StressCurve c = stiffening();
  const double x0 = c.strain_points().front(), xn = c.strain_points().back();
  const double m0 = c.tangent(x0), mn = c.tangent(xn);
  for (double d : {1e-3, 0.01, 0.1}) {
    EXPECT_NEAR(c.stress(xn + d), c.stress_points().back() + mn * d, 1e-9 * (1 + mn));
    EXPECT_NEAR(c.stress(x0 - d), c.stress_points().front() - m0 * d, 1e-9 * (1 + m0));
    EXPECT_DOUBLE_EQ(c.tangent(xn + d), mn);
    EXPECT_DOUBLE_EQ(c.tangent(x0 - d), m0);
  }
}

TEST(SplineCurve, TwoPointsIsAStraightLine) {
  const StressCurve c = StressCurve::tabulated({0.0, 0.1}, {0.0, 50.0});
  for (double e : samples(-0.1, 0.3, 40)) {
    EXPECT_NEAR(c.stress(e), 500.0 * e, 1e-9);
    EXPECT_NEAR(c.energy(e), 250.0 * e * e, 1e-9);
  }
}

TEST(CurveLinear, StressTangentEnergy) {
  const StressCurve c = StressCurve::linear(400.0);
  EXPECT_TRUE(c.is_linear());
  EXPECT_DOUBLE_EQ(c.stress(0.02), 8.0);
  EXPECT_DOUBLE_EQ(c.tangent(-0.3), 400.0);
  EXPECT_NEAR(fd_energy(c, 0.05), c.stress(0.05), 1e-6);
}

TEST(SplineCurve, OddSymmetricMirrorsTheTable) {
  const StressCurve c = StressCurve::odd_symmetric({0.0, 0.02, 0.05, 0.1}, {0.0, 1.0, 3.0, 9.0});
  for (double e : samples(0.0, 0.2, 80)) {
    EXPECT_NEAR(c.stress(-e), -c.stress(e), 1e-12) << e;
    EXPECT_NEAR(c.energy(-e), c.energy(e), 1e-12) << e;
  }
  EXPECT_GT(c.tangent(0.0), 0.0);
  // A table not starting at 0 gets (0, 0) added.
  const StressCurve d = StressCurve::odd_symmetric({0.02, 0.05}, {1.0, 3.0});
  EXPECT_EQ(d.stress(0.0), 0.0);
  EXPECT_NEAR(d.stress(-0.02), -1.0, 1e-12);
  EXPECT_THROW(StressCurve::odd_symmetric({0.0, 0.1}, {1.0, 2.0}), InputError);
  EXPECT_THROW(StressCurve::odd_symmetric({-0.1, 0.1}, {-1.0, 1.0}), InputError);
}

TEST(SplineCurve, LoadUnloadBranchesAveragedOnUnionOfStrains) {
  const std::vector<double> lx{0.0, 0.02, 0.04, 0.06}, ly{0.0, 20.0, 60.0, 150.0};
  // Unloading recorded downwards, on other strains and a shorter range.
  const std::vector<double> ux{0.05, 0.03, 0.01, 0.0}, uy{90.0, 25.0, 3.0, 0.0};
  const auto [x, y] = StressCurve::average_branches(lx, ly, ux, uy, "t");
  const StressCurve load = StressCurve::tabulated(lx, ly);
  const StressCurve unload = StressCurve::tabulated({0.0, 0.01, 0.03, 0.05}, {0.0, 3.0, 25.0, 90.0});
  const std::vector<double> expected_x{0.0, 0.01, 0.02, 0.03, 0.04, 0.05};
  ASSERT_EQ(x.size(), expected_x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    EXPECT_DOUBLE_EQ(x[i], expected_x[i]);
    EXPECT_NEAR(y[i], 0.5 * (load.stress(x[i]) + unload.stress(x[i])), 1e-12);
    EXPECT_LE(y[i], load.stress(x[i]) + 1e-12);
    EXPECT_GE(y[i], unload.stress(x[i]) - 1e-12);
  }
  EXPECT_THROW(StressCurve::average_branches(lx, ly, {0.07, 0.08}, {1.0, 2.0}, "t"), InputError);
}

TEST(SplineCurve, RejectsBadTables) {
  auto message = [](std::vector<double> x, std::vector<double> y) {
    try {
      StressCurve::tabulated(std::move(x), std::move(y), "here");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({0.0, 0.02, 0.01}, {0, 1, 2}).find("here.strain"), std::string::npos);
  EXPECT_NE(message({0.0, 0.01}, {0, 1, 2}).find("here"), std::string::npos);
  EXPECT_NE(message({}, {}).find("empty"), std::string::npos);
  EXPECT_NE(message({0.0}, {0.0}).find("at least 2"), std::string::npos);
  EXPECT_NE(message({0.0, NAN}, {0, 1}).find("not finite"), std::string::npos);
  EXPECT_NE(message({0.0, 0.0}, {0, 1}).find("strictly increasing"), std::string::npos);
}

}  // namespace
}  // namespace weft
