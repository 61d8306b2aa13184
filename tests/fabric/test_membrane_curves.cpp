// The membrane with nonlinear (tabulated, stiffening) curves: forces against finite
// differences of the energy and the exact Jacobian against finite differences of the forces,
// at strains across the whole curve including its steep end; and the stiffness factor used by
// adaptive damping following the tangent of the curve at the current strain.
#include <gtest/gtest.h>

#include <random>

#include "elements/membrane.hpp"
#include "mesh/mesh.hpp"
#include "support/membrane_fd.hpp"
#include "system/cloth.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

// A deformed triangle: stretch e along u (Green strain, before the shear and rotation), a
// smaller stretch along v, a shear, a rotation.
std::array<Vec3, 3> deformed(const std::array<Vec2, 3>& p, double stretch_u, double stretch_v, double shear,
                             const Mat3& R) {
  Mat3 F = Mat3::Identity();
  F(0, 0) = stretch_u;
  F(1, 1) = stretch_v;
  F(0, 1) = shear;
  std::array<Vec3, 3> x;
  for (int i = 0; i < 3; ++i) x[i] = R * F * Vec3(p[i].x(), p[i].y(), 0);
  return x;
}

}  // namespace

TEST(NonlinearMembrane, ForcesAndExactJacobiansMatchFiniteDifferencesAcrossTheCurve) {
  const Material mat = material_preset("denim");
  ASSERT_FALSE(mat.weft.is_linear());
  const double e_end_weft = mat.weft.strain_points().back();
  const double e_end_warp = mat.warp.strain_points().back();
  const std::array<Vec2, 3> p{Vec2(0.0, 0.0), Vec2(0.02, 0.001), Vec2(0.004, 0.018)};
  MembraneGeometry g;
  ASSERT_TRUE(make_membrane_geometry(p[0], p[1], p[2], g));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1, 1);
  // Fractions of the curves' range: the soft start, the middle, the steep end, past the end.
  for (double fraction : {0.05, 0.3, 0.6, 0.9, 1.05}) {
    const double su = std::sqrt(1 + 2 * fraction * e_end_weft), sv = std::sqrt(1 + 2 * 0.5 * fraction * e_end_warp);
    const Mat3 R = Eigen::AngleAxisd(3 * uni(rng), Vec3(uni(rng), uni(rng), uni(rng)).normalized()).toRotationMatrix();
    const auto x = deformed(p, su, sv, 0.03 * uni(rng), R);
    const std::array<Vec3, 3> v{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    MembraneResult r;
    evaluate_membrane(g, mat, Vec3::Zero(), x, v, true, false, r);
    // The strain really reaches the intended part of the curve (the tangent there is steep).
    EXPECT_NEAR(r.strain[0], fraction * e_end_weft, 0.02 * e_end_weft);
    if (fraction >= 0.9) EXPECT_GT(mat.weft.tangent(r.strain[0]), 10 * mat.weft.tangent(0.0));

    // Central differences: truncation error O(h^2 f''') for the energy (C2) and O(h) at most
    // where the force's derivative has a kink (the spline is C1, its tangent only C0); with
    // h = 1e-8 m on a 2 cm triangle the strain step is ~1e-6, far below the knot spacing,
    // while rounding contributes ~eps |f| / h ~ 1e-8 relative.
    const double h = 1e-8;
    const auto fd = weft::test::membrane_finite_differences(g, mat, x, v, h);
    const auto& grad = fd.energy_gradient;
    const auto& Kfd = fd.force_jacobian;
    EXPECT_LT((r.force + grad).norm(), 1e-5 * r.force.norm()) << "fraction " << fraction;
    EXPECT_LT((r.stiffness - Kfd).norm(), 1e-5 * r.stiffness.norm()) << "fraction " << fraction;
    // The exact Jacobian is symmetric (a Hessian).
    EXPECT_LT((r.stiffness - r.stiffness.transpose()).norm(), 1e-12 * r.stiffness.norm());
  }
}

TEST(NonlinearMembrane, AdaptiveDampingStiffnessFactorFollowsTheCurveTangent) {
  // A grid stretched uniformly along the weft: the largest kappa must follow the weft tangent
  // at the current strain (docs/method.md 4: nonlinear laws use the tangent stiffness every step).
  const Material mat = material_preset("cotton");
  const ClothModel model = build_cloth_model(make_grid(0.1, 0.1, 6, 6), mat, Vec3::Zero(), {});
  const ClothSystem system(model, DampingSettings{0.05});
  const double dt = 0.005, e_end = mat.weft.strain_points().back();
  double previous = 0, first = 0;
  const int samples = 8;
  for (int k = 0; k <= samples; ++k) {
    const double e = e_end * k / samples;
    VecX x = model.initial_positions();
    for (int i = 0; i < model.num_vertices(); ++i) x[3 * i] *= std::sqrt(1 + 2 * e);
    const auto kappa = system.membrane_kappa_max(x, dt);
    const double largest = *std::max_element(kappa.begin(), kappa.end());
    if (k == 0) {
      first = largest;
    } else {
      EXPECT_GT(largest, previous) << "strain " << e;
    }
    previous = largest;
  }
  // The curve stiffens by more than an order of magnitude over its range; kappa must too, by
  // at least the weft tangent's growth relative to the stiffest mode at rest.
  const double at_rest = std::max({mat.weft.tangent(0), mat.warp.tangent(0), mat.shear.tangent(0)});
  EXPECT_GT(previous / first, 0.5 * mat.weft.tangent(e_end) / at_rest);
  EXPECT_GT(previous / first, 10.0);
}

// A sheet rolled into a cylinder (an isometry, so only the bending elements store energy)
// stores the continuum bending energy B k^2 / 2 per area with the plate element, rolled along
// either yarn direction (each with its own rigidity). (The hinge element stores a third of it
// on this grid: docs/fabric-validation.md.)
TEST(BendingCalibration, RolledGridStoresTheContinuumBendingEnergy) {
  Material mat = material_preset("cotton");
  const double curvature = 5.0, size = 0.1;
  const int n = 40;
  const ClothModel model = build_cloth_model(make_grid(size, size, n + 1, n + 1), mat, Vec3::Zero(), {}, BendingModel::kPlate);
  ClothSystem system(model, DampingSettings{});
  for (int axis = 0; axis < 2; ++axis) {
    VecX x = model.initial_positions();
    for (int i = 0; i < model.num_vertices(); ++i) {
      const double s = x[3 * i + axis];
      x[3 * i + axis] = std::sin(curvature * s) / curvature;
      x[3 * i + 2] = (1 - std::cos(curvature * s)) / curvature;
    }
    Evaluation e;
    system.prepare(e);
    system.evaluate(x, VecX::Zero(x.size()), false, e);
    const double B = axis == 0 ? mat.bending_rigidity_weft_Nm : mat.bending_rigidity_warp_Nm;
    const double continuum = 0.5 * B * curvature * curvature * size * size;
    EXPECT_NEAR(e.elastic_energy / continuum, 1.0, 0.02) << "axis " << axis;
  }
}
