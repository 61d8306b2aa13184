// Stability of the alpha family and progressive BDF-2 on one damped spring (docs/method.md 3).
#include <cstring>
#include <gtest/gtest.h>

#include "support/command.hpp"
#include "support/png.hpp"
#include <png.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "weft/error.hpp"
#include "weft/stability.hpp"
#include "weft/stability_image.hpp"

namespace {

using weft::alpha_family_is_stable;
using weft::test::PngInfo;
using weft::test::read_png;
using weft::alpha_family_spectral_radius;
using weft::alpha_family_step_matrix;
using weft::bdf2_spectral_radius;
using weft::bdf2_step_matrix;
using Complex = std::complex<double>;

const double kInvSqrt3 = 1.0 / std::sqrt(3.0);

/// Sorts complex numbers by real then imaginary part so two eigenvalue lists can be paired.
std::vector<Complex> sorted(std::vector<Complex> z) {
  std::sort(z.begin(), z.end(), [](Complex a, Complex b) {
    return a.real() != b.real() ? a.real() < b.real() : a.imag() < b.imag();
  });
  return z;
}

/// Pairs every value of `expected` with its nearest unused value of `actual`.
void expect_same_multiset(const std::vector<Complex>& expected, std::vector<Complex> actual,
                          double tolerance, const std::string& where) {
  ASSERT_EQ(expected.size(), actual.size());
  for (Complex e : expected) {
    auto nearest = std::min_element(actual.begin(), actual.end(), [e](Complex a, Complex b) {
      return std::abs(a - e) < std::abs(b - e);
    });
    EXPECT_LT(std::abs(*nearest - e), tolerance) << where << ": eigenvalue " << e << " not found";
    actual.erase(nearest);
  }
}

TEST(StabilityAlphaFamily, StepMatrixMatchesMethodClosedForm) {
  for (double alpha : {0.0, 0.25, 0.5, kInvSqrt3, 0.75, 1.0})
    for (double kappa : {0.01, 0.7, 3.0, 40.0})
      for (double lambda : {0.0, 0.05, 1.3, 12.0}) {
        const Eigen::Matrix2d h = alpha_family_step_matrix(alpha, kappa, lambda);
        // docs/method.md 3, with D = 1 + lambda alpha + kappa alpha^2.
        const double d = 1.0 + lambda * alpha + kappa * alpha * alpha;
        Eigen::Matrix2d expected;
        expected << 1.0 - kappa * alpha / d, 1.0 / d, -kappa / d, 1.0 - (lambda + kappa * alpha) / d;
        EXPECT_LT((h - expected).cwiseAbs().maxCoeff(), 1e-13)
            << "alpha " << alpha << " kappa " << kappa << " lambda " << lambda;

        // Eigenvalues of H against z = [(1 - lambda/2) + (lambda - kappa) alpha + kappa alpha^2
        //                                 +- sqrt(lambda^2/4 - kappa)] / D.
        const Complex mean = (1.0 - lambda / 2 + (lambda - kappa) * alpha + kappa * alpha * alpha);
        const Complex root = std::sqrt(Complex(lambda * lambda / 4 - kappa, 0.0));
        const std::vector<Complex> closed_form{(mean + root) / d, (mean - root) / d};
        const Eigen::EigenSolver<Eigen::Matrix2d> solver(h, false);
        const std::vector<Complex> computed{solver.eigenvalues()(0), solver.eigenvalues()(1)};
        std::ostringstream where;
        where << "alpha " << alpha << " kappa " << kappa << " lambda " << lambda;
        expect_same_multiset(closed_form, computed, 1e-7, where.str());
        EXPECT_NEAR(alpha_family_spectral_radius(alpha, kappa, lambda),
                    solver.eigenvalues().cwiseAbs().maxCoeff(), 1e-7)
            << where.str();
      }
}

TEST(StabilityAlphaFamily, StepMatrixAdvancesTheLinearisedSpring) {
  // One step of docs/method.md 1 written for the spring (dt = 1 in the scaled variables):
  // (1 - alpha lambda' - alpha^2 kappa') dv = f + alpha K v with f = -kappa p - lambda v.
  const double alpha = 0.3, kappa = 2.5, lambda = 0.4, p = 0.7, v = -1.1;
  const double dv = (-kappa * p - lambda * v - alpha * kappa * v) /
                    (1.0 + alpha * lambda + alpha * alpha * kappa);
  const double dp = v + alpha * dv;
  const Eigen::Vector2d next = alpha_family_step_matrix(alpha, kappa, lambda) * Eigen::Vector2d(p, v);
  EXPECT_NEAR(next(0), p + dp, 1e-14);
  EXPECT_NEAR(next(1), v + dv, 1e-14);
}

/// Distance (in lambda) from (kappa, lambda) to the nearest boundary curve of (10a)-(10c);
/// (10a) kappa = 0 is measured in kappa.
double distance_to_boundary(double alpha, double kappa, double lambda) {
  const double s = 1.0 - 2.0 * alpha;
  double distance = std::min(std::abs(kappa), std::abs(lambda - s * kappa));
  if (s > 0.0) distance = std::min(distance, std::abs(lambda - (2.0 / s + kappa * s / 2.0)));
  return distance;
}

TEST(StabilityAlphaFamily, AnalyticConditionsAgreeWithSpectralRadius) {
  const double margin = 0.02;
  for (double alpha : {0.0, 0.25, 0.5, 0.75, 1.0}) {
    int stable = 0, unstable = 0, disagreements = 0;
    for (int i = 0; i <= 300; ++i)
      for (int j = 0; j <= 300; ++j) {
        const double kappa = 12.0 * i / 300, lambda = 12.0 * j / 300;
        if (distance_to_boundary(alpha, kappa, lambda) < margin) continue;
        const bool predicted = alpha_family_is_stable(alpha, kappa, lambda);
        const double radius = alpha_family_spectral_radius(alpha, kappa, lambda);
        if (predicted != (radius < 1.0)) {
          if (++disagreements <= 5)
            ADD_FAILURE() << "alpha " << alpha << " kappa " << kappa << " lambda " << lambda
                          << ": (10) says " << predicted << ", spectral radius " << radius;
        }
        (predicted ? stable : unstable)++;
      }
    EXPECT_EQ(disagreements, 0) << "alpha " << alpha;
    EXPECT_GT(stable, 1000) << "alpha " << alpha;
    // Below alpha = 1/2 (10b) and (10c) both cut the grid, so both outcomes must occur.
    if (alpha < 0.5) EXPECT_GT(unstable, 1000) << "alpha " << alpha;
  }
}

TEST(StabilityAlphaFamily, ConditionsAssumeNonNegativeViscosity) {
  // (10) omits 4 - 2 (1 - 2 alpha) lambda + (1 - 2 alpha)^2 kappa > 0, which only binds for
  // alpha > 1/2 when lambda < 0: Backward Euler with kappa = 10, lambda = -9 passes (10b)
  // (lambda > -kappa) yet is unstable. The predicate is documented for lambda >= 0.
  EXPECT_TRUE(alpha_family_is_stable(1.0, 10.0, -9.0));
  EXPECT_GT(alpha_family_spectral_radius(1.0, 10.0, -9.0), 1.0);
  EXPECT_LT(4.0 - 2.0 * (1.0 - 2.0) * -9.0 + (1.0 - 2.0) * (1.0 - 2.0) * 10.0, 0.0);
}

TEST(StabilityAlphaFamily, MethodSpecialCases) {
  // docs/method.md 3: FE needs kappa < lambda < 2 + kappa/2, IM lambda > 0, BE always stable.
  for (double kappa : {0.5, 2.0, 3.5}) {
    EXPECT_LT(alpha_family_spectral_radius(0.0, kappa, (kappa + 2.0 + kappa / 2) / 2), 1.0);
    EXPECT_GT(alpha_family_spectral_radius(0.0, kappa, 0.9 * kappa), 1.0);
    EXPECT_GT(alpha_family_spectral_radius(0.0, kappa, 1.1 * (2.0 + kappa / 2)), 1.0);
  }
  // FE has no stable lambda once kappa >= 4 (the interval kappa < lambda < 2 + kappa/2 is empty).
  for (int j = 0; j <= 1000; ++j) EXPECT_GE(alpha_family_spectral_radius(0.0, 4.5, 0.01 * j), 1.0);
  for (double kappa : {1e-3, 1.0, 1e3}) {
    EXPECT_NEAR(alpha_family_spectral_radius(0.5, kappa, 0.0), 1.0, 1e-12);  // undamped: |z| = 1
    EXPECT_LT(alpha_family_spectral_radius(0.5, kappa, 1e-3), 1.0);
    EXPECT_LT(alpha_family_spectral_radius(1.0, kappa, 0.0), 1.0);
  }
}

TEST(StabilityAlphaFamily, FastestDecayAtCriticalDamping) {
  // For fixed kappa, |z| falls with lambda while the eigenvalues are a complex pair
  // (|z|^2 = det H decreases in lambda) and rises once they split into two real ones, so
  // the minimum over lambda is where lambda^2/4 - kappa = 0, for every alpha.
  for (double alpha : {0.0, 0.25, 0.5, 1.0})
    for (double kappa : {0.05, 0.5, 1.0, 2.0, 9.0}) {
      if (alpha == 0.0 && kappa >= 4.0) continue;  // FE: no stable lambda there
      const double critical = 2.0 * std::sqrt(kappa);
      const int samples = 4000;
      const double step = 3.0 * critical / samples;
      int best = 0;
      double best_radius = INFINITY;
      for (int j = 0; j <= samples; ++j) {
        const double radius = alpha_family_spectral_radius(alpha, kappa, step * j);
        if (radius < best_radius) best_radius = radius, best = j;
      }
      EXPECT_NEAR(step * best, critical, step) << "alpha " << alpha << " kappa " << kappa;
      const double at_critical = alpha_family_spectral_radius(alpha, kappa, critical);
      EXPECT_LT(at_critical, alpha_family_spectral_radius(alpha, kappa, critical * (1 - 1e-6)));
      EXPECT_LT(at_critical, alpha_family_spectral_radius(alpha, kappa, critical * (1 + 1e-6)));
    }
}

TEST(StabilityBdf2, EigenvaluesSolveTheSchemeCharacteristicEquation) {
  // With q_n = z^n w for an eigenvector w of B (eigenvalue mu), progressive BDF-2
  // q_{n+1} - q_n = beta (q_n - q_{n-1}) + c B (q_n + alpha (q_{n+1} - q_n)) gives
  // (1 - alpha c mu) z^2 - (1 + beta + c (1 - alpha) mu) z + beta = 0.
  for (double alpha : {1.0 / 3.0, 0.5, kInvSqrt3, 0.8, 1.0})
    for (double kappa : {0.01, 1.0, 30.0})
      for (double lambda : {0.0, 0.3, 5.0}) {
        const double beta = (2 * alpha - 1) / (2 * alpha + 1), c = 2 / (2 * alpha + 1);
        const Complex root = std::sqrt(Complex(lambda * lambda / 4 - kappa, 0.0));
        std::vector<Complex> expected;
        for (Complex mu : {-lambda / 2 + root, -lambda / 2 - root}) {
          const Complex a = 1.0 - alpha * c * mu, b = -(1.0 + beta + c * (1 - alpha) * mu);
          const Complex sq = std::sqrt(b * b - 4.0 * a * beta);
          expected.push_back((-b + sq) / (2.0 * a));
          expected.push_back((-b - sq) / (2.0 * a));
        }
        const Eigen::EigenSolver<Eigen::Matrix4d> solver(bdf2_step_matrix(alpha, kappa, lambda), false);
        std::vector<Complex> computed;
        for (int k = 0; k < 4; ++k) computed.push_back(solver.eigenvalues()(k));
        std::ostringstream where;
        where << "alpha " << alpha << " kappa " << kappa << " lambda " << lambda;
        expect_same_multiset(expected, computed, 1e-6, where.str());
      }
}

TEST(StabilityBdf2, HalfAlphaIsImplicitMidpoint) {
  // beta = 0 and dt_b = dt at alpha = 1/2 (docs/method.md 2): the history drops out.
  for (double kappa : {0.1, 2.0, 50.0})
    for (double lambda : {0.0, 0.5, 8.0})
      EXPECT_NEAR(bdf2_spectral_radius(0.5, kappa, lambda),
                  alpha_family_spectral_radius(0.5, kappa, lambda), 1e-9);
}

TEST(StabilityBdf2, StableForAllStiffnessAndDamping) {
  // docs/method.md 3: alpha = 1 and 1/sqrt(3) are stable for all kappa > 0, lambda >= 0.
  std::vector<double> values;
  for (int e = -40; e <= 60; ++e) values.push_back(std::pow(10.0, e / 10.0));  // 1e-4 .. 1e6
  for (double alpha : {1.0, kInvSqrt3}) {
    double worst = 0.0;
    for (double kappa : values) {
      worst = std::max(worst, bdf2_spectral_radius(alpha, kappa, 0.0));
      for (double lambda : values) worst = std::max(worst, bdf2_spectral_radius(alpha, kappa, lambda));
    }
    EXPECT_LE(worst, 1.0 + weft::kStabilityTolerance) << "alpha " << alpha;
  }
  // The same check finds the instability of the third-order point alpha = 1/3 (docs/method.md 2).
  double worst_third = 0.0;
  for (double kappa : values) worst_third = std::max(worst_third, bdf2_spectral_radius(1.0 / 3.0, kappa, 0.0));
  EXPECT_GT(worst_third, 1.0 + 1e-6);
}

TEST(StabilityMap, GridAndStableFlags) {
  const auto scheme = weft::stability_scheme_by_name("forward-euler", NAN);
  const weft::StabilityMap map = weft::compute_stability_map(scheme, 6.0, 5.0, 61);
  ASSERT_EQ(map.kappa.size(), 61u);
  EXPECT_EQ(map.kappa.front(), 0.0);
  EXPECT_EQ(map.kappa.back(), 6.0);
  EXPECT_EQ(map.lambda.back(), 5.0);
  for (int i = 1; i < 61; ++i)
    for (int j = 0; j < 61; ++j) {
      EXPECT_EQ(map.spectral_radius(i, j), alpha_family_spectral_radius(0.0, map.kappa[i], map.lambda[j]));
      if (distance_to_boundary(0.0, map.kappa[i], map.lambda[j]) > 0.02)
        EXPECT_EQ(map.stable(i, j), alpha_family_is_stable(0.0, map.kappa[i], map.lambda[j]));
    }
}

TEST(StabilityMap, SameBitsAtEveryThreadCount) {
  // The map is the one computation of weft split over threads: one thread, two, an odd
  // count that does not divide the rows, and more threads than rows must give the same bits.
  const auto scheme = weft::stability_scheme_by_name("implicit-midpoint", NAN);
  const weft::StabilityMap one = weft::compute_stability_map(scheme, 50.0, 8.0, 37, 1);
  for (int threads : {2, 3, 7, 64}) {
    const weft::StabilityMap many = weft::compute_stability_map(scheme, 50.0, 8.0, 37, threads);
    ASSERT_EQ(many.spectral_radius.rows(), 37);
    EXPECT_EQ(0, std::memcmp(one.spectral_radius.data(), many.spectral_radius.data(),
                             sizeof(double) * one.spectral_radius.size()))
        << threads << " threads";
  }
}

TEST(StabilityMap, LargeMapsMatchPointwiseValues) {
  // Large maps are filled by several threads; every entry must still be the pointwise value.
  const auto scheme = weft::stability_scheme_by_name("bdf2-alpha", NAN);
  const int size = 301;
  const weft::StabilityMap map = weft::compute_stability_map(scheme, 20.0, 10.0, size);
  int mismatches = 0;
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j)
      mismatches += map.spectral_radius(i, j) != bdf2_spectral_radius(scheme.alpha, map.kappa[i], map.lambda[j]);
  EXPECT_EQ(mismatches, 0);
}

TEST(StabilityMap, SchemeNames) {
  using Kind = weft::StabilityScheme::Kind;
  EXPECT_EQ(weft::stability_scheme_by_name("backward-euler", NAN).alpha, 1.0);
  EXPECT_EQ(weft::stability_scheme_by_name("implicit-midpoint", NAN).alpha, 0.5);
  EXPECT_EQ(weft::stability_scheme_by_name("bdf2", NAN).kind, Kind::kProgressiveBdf2);
  EXPECT_NEAR(weft::stability_scheme_by_name("bdf2-alpha", NAN).alpha, kInvSqrt3, 1e-15);
  EXPECT_EQ(weft::stability_scheme_by_name("alpha", 0.3).alpha, 0.3);
  EXPECT_THROW(weft::stability_scheme_by_name("alpha", NAN), weft::InputError);
  EXPECT_THROW(weft::stability_scheme_by_name("alpha", -0.1), weft::InputError);
  EXPECT_THROW(weft::stability_scheme_by_name("forward-euler", 0.3), weft::InputError);
  EXPECT_THROW(weft::stability_scheme_by_name("rk4", NAN), weft::InputError);
}

TEST(StabilityImage, PlotPixelsFollowTheMap) {
  const auto scheme = weft::stability_scheme_by_name("forward-euler", NAN);
  const weft::StabilityMap map = weft::compute_stability_map(scheme, 5.0, 4.0, 50);
  const weft::StabilityImage picture = weft::render_stability_image(map, "forward-euler");
  const auto& layout = picture.layout;
  ASSERT_GE(picture.image.width, layout.plot_left + 50);
  ASSERT_GE(picture.image.height, layout.plot_top + 50);
  int white = 0, dark = 0;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j) {
      // lambda increases upward: grid row j is image row plot_top + size - 1 - j.
      const int pixel = picture.image.at(layout.plot_left + i, layout.plot_top + 49 - j);
      EXPECT_EQ(pixel, weft::stability_grey_level(map.spectral_radius(i, j)));
      EXPECT_EQ(pixel == 255, !map.stable(i, j));
      white += pixel == 255;
      dark += pixel < 128;
    }
  EXPECT_GT(white, 0);
  EXPECT_GT(dark, 0);
  // Axis frame just left of and below the plot.
  EXPECT_EQ(picture.image.at(layout.plot_left - 1, layout.plot_top + 10), 0);
  EXPECT_EQ(picture.image.at(layout.plot_left + 10, layout.plot_top + 50), 0);
  // Smaller radius is darker.
  EXPECT_LT(weft::stability_grey_level(0.2), weft::stability_grey_level(0.8));
  EXPECT_LT(weft::stability_grey_level(1.0), 255);
  EXPECT_EQ(weft::stability_grey_level(1.0 + 1e-6), 255);
}

// --- the `weft stability` command -------------------------------------------------------

using weft::test::CommandResult;

// The command writes nothing but its own files into the test's folder.
class StabilityCommand : public weft::test::CommandTest {
 protected:
  CommandResult run(const std::string& arguments) { return weft("stability " + arguments); }
  size_t files_in_folder() const {
    return static_cast<size_t>(std::distance(std::filesystem::directory_iterator(folder_),
                                             std::filesystem::directory_iterator()));
  }
};

TEST_F(StabilityCommand, BadParametersExitTwoNamingTheOption) {
  const std::string out = " --out '" + (folder_ / "map.png").string() + "'";
  const std::string good = " --kappa-max 5 --lambda-max 4 --size 20";
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--method forward-euler --kappa-max -1 --lambda-max 4 --size 20", "--kappa-max"},
      {"--method forward-euler --kappa-max nan --lambda-max 4 --size 20", "--kappa-max"},
      {"--method forward-euler --kappa-max 5 --lambda-max -2 --size 20", "--lambda-max"},
      {"--method forward-euler --kappa-max 5 --lambda-max 4 --size 1", "--size"},
      {"--method forward-euler --kappa-max 5 --lambda-max 4 --size 100000", "--size"},
      {"--method runge-kutta" + good, "--method"},
      {"--method alpha" + good, "--alpha"},
      {"--method alpha --alpha 1.5" + good, "--alpha"},
      {"--method bdf2-alpha --alpha -0.2" + good, "--alpha"},
      {"--method backward-euler --alpha 0.3" + good, "--alpha"},
  };
  for (const auto& [arguments, option] : cases) {
    const CommandResult result = run(arguments + out);
    EXPECT_EQ(result.exit_code, 2) << arguments;
    EXPECT_NE(result.error_output.find(option), std::string::npos)
        << arguments << " -> " << result.error_output;
    EXPECT_EQ(files_in_folder(), 0u) << arguments << ": wrote something";
  }
}

TEST_F(StabilityCommand, WritesPngAndCsv) {
  const int size = 40;
  const auto png_path = folder_ / "sub" / "fe.png";
  const CommandResult result =
      run("--method forward-euler --kappa-max 5 --lambda-max 4 --size " + std::to_string(size) +
          " --out '" + png_path.string() + "'");
  ASSERT_EQ(result.exit_code, 0) << result.error_output;

  const PngInfo png = read_png(png_path);
  ASSERT_TRUE(png.signature_ok);
  EXPECT_EQ(png.color_type, PNG_COLOR_TYPE_GRAY);
  EXPECT_EQ(png.bit_depth, 8);
  // The plot itself plus margins for labels on every side.
  EXPECT_GT(png.width, static_cast<unsigned>(size));
  EXPECT_GT(png.height, static_cast<unsigned>(size));
  // Same picture as the library renders for the same map.
  const weft::StabilityMap map = weft::compute_stability_map(
      weft::stability_scheme_by_name("forward-euler", NAN), 5.0, 4.0, size);
  const auto layout = weft::render_stability_image(map, "").layout;
  int mismatches = 0;
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j)
      mismatches += png.pixels[(layout.plot_top + size - 1 - j) * png.width + layout.plot_left + i] !=
                    weft::stability_grey_level(map.spectral_radius(i, j));
  EXPECT_EQ(mismatches, 0);

  std::ifstream csv(folder_ / "sub" / "fe.csv");
  ASSERT_TRUE(csv.good());
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "kappa,lambda,spectral_radius,stable");
  int rows = 0, stable_rows = 0;
  double kappa_max = 0, lambda_max = 0;
  while (std::getline(csv, line)) {
    double kappa, lambda, radius;
    int stable;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%d", &kappa, &lambda, &radius, &stable), 4) << line;
    EXPECT_EQ(stable == 1, radius <= 1.0 + weft::kStabilityTolerance) << line;
    EXPECT_EQ(radius, alpha_family_spectral_radius(0.0, kappa, lambda)) << line;
    kappa_max = std::max(kappa_max, kappa);
    lambda_max = std::max(lambda_max, lambda);
    ++rows;
    stable_rows += stable;
  }
  EXPECT_EQ(rows, size * size);
  EXPECT_GT(stable_rows, 0);
  EXPECT_LT(stable_rows, rows);
  EXPECT_EQ(kappa_max, 5.0);
  EXPECT_EQ(lambda_max, 4.0);
  // No temporary files left behind.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(folder_ / "sub"),
                          std::filesystem::directory_iterator()),
            2);
}

}  // namespace
