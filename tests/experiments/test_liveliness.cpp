// The walk's liveliness measures on constructed cases: a garment moving rigidly with the body
// has no kinetic energy relative to it, a known swing gives its amplitude, and the hem is found.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "weft/experiments/liveliness.hpp"

using namespace weft;

namespace {

Points random_points(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  Points p(n, 3);
  for (int i = 0; i < n; ++i) p.row(i) << u(rng), 1 + u(rng), u(rng);
  return p;
}

}  // namespace

TEST(Liveliness, ARigidMotionIsFittedExactlyAndLeavesNoRelativeKineticEnergy) {
  std::mt19937 rng(7);
  const Vec3 linear(1.2, -0.3, 0.5), angular(0.4, 2.0, -0.7), pivot(0.1, 0.9, -0.2);
  const Points body = random_points(200, rng);
  Points body_v(body.rows(), 3);
  for (Eigen::Index i = 0; i < body.rows(); ++i)
    body_v.row(i) = (linear + angular.cross(body.row(i).transpose() - pivot)).transpose();
  const RigidVelocity fit = fit_rigid_velocity(body, body_v);
  EXPECT_LT((fit.angular - angular).norm(), 1e-12);
  // A cloth elsewhere moving with the same rigid motion.
  const Points cloth = random_points(50, rng);
  VecX x(150), v(150), mass = VecX::Constant(50, 0.01);
  for (int i = 0; i < 50; ++i) {
    x.segment<3>(3 * i) = cloth.row(i).transpose();
    v.segment<3>(3 * i) = linear + angular.cross(cloth.row(i).transpose() - pivot);
  }
  EXPECT_LT(relative_kinetic_energy(x, v, mass, fit), 1e-24);
  // Relative to a body at rest, the same cloth has its whole kinetic energy.
  const RigidVelocity still = fit_rigid_velocity(body, Points::Zero(body.rows(), 3));
  EXPECT_NEAR(relative_kinetic_energy(x, v, mass, still), 0.5 * 0.01 * v.squaredNorm(), 1e-12);
  // One vertex 0.3 m/s off the rigid motion: 0.01 * 0.09 / 2.
  v.segment<3>(30) += Vec3(0, 0, 0.3);
  EXPECT_NEAR(relative_kinetic_energy(x, v, mass, fit), 0.5 * 0.01 * 0.09, 1e-15);
}

TEST(Liveliness, PointsOnALineFitWithoutSpinAboutIt) {
  Points p(5, 3), v(5, 3);
  for (int i = 0; i < 5; ++i) {
    p.row(i) << i, 0, 0;
    v.row(i) << 0, 0.5 * i, 0;  // turning about z at 0.5 rad/s about x = 0, plus translation
  }
  const RigidVelocity fit = fit_rigid_velocity(p, v);
  EXPECT_LT((fit.angular - Vec3(0, 0, 0.5)).norm(), 1e-12);
  for (int i = 0; i < 5; ++i) EXPECT_LT((fit.at(p.row(i).transpose()) - v.row(i).transpose()).norm(), 1e-12);
}

TEST(Liveliness, AKnownSwingGivesItsAmplitude) {
  // The hem swinging forward and back as 0.07 sin(2 pi t / 1.1) about an offset, over three
  // periods sampled at 25 frames per second, with a sideways sway that must not count.
  std::vector<Vec3> offsets;
  double sampled_peak = 0;
  for (int f = 0; f <= 82; ++f) {
    const double t = f / 25.0, s = std::sin(2 * M_PI * t / 1.1);
    offsets.emplace_back(0.2 + 0.03 * std::cos(5 * t), -0.6, 0.1 + 0.07 * s);
    sampled_peak = std::max(sampled_peak, std::abs(s));
  }
  const double a = swing_amplitude(offsets, Vec3(0, 0, 2));  // direction normalised
  EXPECT_LE(a, 0.07 + 1e-15);
  EXPECT_GT(a, 0.07 * std::cos(M_PI / 27.5));  // frames at most half a sample from the peaks
  EXPECT_NEAR(swing_amplitude(offsets, Vec3(1, 0, 0)), 0.03, 0.03 * (1 - std::cos(5 * 0.02)) + 1e-12);
  EXPECT_EQ(swing_amplitude({Vec3(1, 2, 3)}, Vec3(0, 0, 1)), 0.0);
}

TEST(Liveliness, TheHemIsTheLowestBoundaryLoop) {
  // An open cylinder (a tube of 8 around and 3 rings): two boundary loops, the lower at y = 0.
  const int around = 8, rings = 3;
  VecX x(3 * around * rings);
  for (int r = 0; r < rings; ++r)
    for (int k = 0; k < around; ++k)
      x.segment<3>(3 * (r * around + k)) = Vec3(std::cos(2 * M_PI * k / around), 0.5 * r, std::sin(2 * M_PI * k / around));
  std::vector<std::array<int, 3>> t;
  for (int r = 0; r + 1 < rings; ++r)
    for (int k = 0; k < around; ++k) {
      const int a = r * around + k, b = r * around + (k + 1) % around, c = a + around, d = b + around;
      t.push_back({a, b, d});
      t.push_back({a, d, c});
    }
  const std::vector<int> hem = lowest_boundary_loop(t, x);
  ASSERT_EQ(hem.size(), static_cast<size_t>(around));
  for (int k = 0; k < around; ++k) EXPECT_EQ(hem[k], k);
  EXPECT_NEAR(mean_of(x, hem).y(), 0.0, 1e-15);
  // Turned upside down, the other loop is the lowest.
  VecX flipped = x;
  for (Eigen::Index i = 1; i < flipped.size(); i += 3) flipped[i] = -flipped[i];
  EXPECT_EQ(lowest_boundary_loop(t, flipped).front(), (rings - 1) * around);
}
