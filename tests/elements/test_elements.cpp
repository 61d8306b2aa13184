// Every element's forces against finite differences of its energy, and its stiffness
// (df/dx) and damping (df/dv) against finite differences of its forces, at random
// deformed states.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>
#include <unsupported/Eigen/KroneckerProduct>

#include "elements/bending.hpp"
#include "elements/membrane.hpp"
#include "elements/spring.hpp"
#include "mesh/mesh.hpp"
#include "support/membrane_fd.hpp"
#include "weft/material.hpp"

using namespace weft;

namespace {

std::mt19937 rng(12345);
double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
Vec3 random_vec(double s) { return Vec3(uniform(-s, s), uniform(-s, s), uniform(-s, s)); }

Material test_material() {
  Material m;
  m.weft = StressCurve::linear(400);
  m.warp = StressCurve::linear(250);
  m.shear = StressCurve::linear(40);
  m.poisson_ratio = 0.3;
  return m;
}

// Relative error of a against b, with a floor on the scale.
double rel_err(const MatX& a, const MatX& b) { return (a - b).norm() / std::max(1e-8, b.norm()); }

}  // namespace

TEST(MembraneElement, ForcesAreMinusEnergyGradientAndJacobiansMatchFiniteDifferences) {
  const Material mat = test_material();
  for (int trial = 0; trial < 20; ++trial) {
    const Vec2 pa(uniform(-0.01, 0.01), uniform(-0.01, 0.01));
    const Vec2 pb = pa + Vec2(0.02 + uniform(0, 0.01), uniform(-0.005, 0.005));
    const Vec2 pc = pa + Vec2(uniform(-0.005, 0.005), 0.02 + uniform(0, 0.01));
    MembraneGeometry g;
    ASSERT_TRUE(make_membrane_geometry(pa, pb, pc, g));
    // A random deformation: rotation, stretch or compression up to 15%, shear, noise.
    const Mat3 R = Eigen::AngleAxisd(uniform(0, 6.28), random_vec(1).normalized()).toRotationMatrix();
    Mat3 F = Mat3::Identity() + 0.15 * Mat3::Random();
    std::array<Vec3, 3> x, v;
    const Vec2 p[3] = {pa, pb, pc};
    for (int i = 0; i < 3; ++i) {
      x[i] = R * F * Vec3(p[i].x(), p[i].y(), 0) + random_vec(1e-3);
      v[i] = random_vec(0.5);
    }
    const Vec3 eta(0.02, 0.03, 0.01);
    MembraneResult r;
    evaluate_membrane(g, mat, Vec3::Zero(), x, v, true, false, r);
    const double h = 1e-7;
    const auto fd = weft::test::membrane_finite_differences(g, mat, x, v, h);
    const auto& grad = fd.energy_gradient;
    const auto& Kfd = fd.force_jacobian;
    Eigen::Matrix<double, 9, 9> Dfd;
    EXPECT_LT(rel_err(r.force, -grad), 1e-6) << "trial " << trial;
    EXPECT_LT(rel_err(r.stiffness, Kfd), 1e-6) << "trial " << trial;
    EXPECT_LT((r.stiffness - r.stiffness.transpose()).norm(), 1e-9 * r.stiffness.norm());
    // Damping: forces with viscosity against finite differences in velocity.
    MembraneResult rv;
    evaluate_membrane(g, mat, eta, x, v, true, false, rv);
    for (int k = 0; k < 9; ++k) {
      auto vp = v, vm = v;
      vp[k / 3][k % 3] += h;
      vm[k / 3][k % 3] -= h;
      MembraneResult rp, rm;
      evaluate_membrane(g, mat, eta, x, vp, false, false, rp);
      evaluate_membrane(g, mat, eta, x, vm, false, false, rm);
      Dfd.col(k) = (rp.force - rm.force) / (2 * h);
    }
    EXPECT_LT(rel_err(rv.damping, Dfd), 1e-6) << "trial " << trial;
    // Viscous power equals viscous force . v.
    Eigen::Matrix<double, 9, 1> vv;
    for (int i = 0; i < 3; ++i) vv.segment<3>(3 * i) = v[i];
    EXPECT_NEAR(rv.viscous_power, (rv.force - r.force).dot(vv), 1e-9 * std::abs(rv.viscous_power) + 1e-15);
    EXPECT_LE(rv.viscous_power, 0.0);
  }
}

TEST(MembraneElement, CompressionSoftenedCurvesMatchFiniteDifferences) {
  // Weft and warp ten and twenty times softer in compression (docs/materials.md), through the
  // triangle-at-a-time path of curved materials, in stretched, compressed and mixed states.
  Material mat = parse_material(nlohmann::json{{"weft", {{"linear", 400}, {"compression", 0.1}}},
                                               {"warp", {{"linear", 250}, {"compression", 0.05}}},
                                               {"shear", 40}},
                                "test material");
  MembraneGeometry g;
  ASSERT_TRUE(make_membrane_geometry(Vec2(0, 0), Vec2(0.02, 0.003), Vec2(-0.002, 0.02), g));
  int compressed = 0;
  for (int trial = 0; trial < 30; ++trial) {
    std::array<Vec3, 3> x{Vec3(0, 0, 0), Vec3(0.02 * uniform(0.8, 1.2), 0.003, 0), Vec3(-0.002, 0.02 * uniform(0.8, 1.2), 0)};
    for (auto& p : x) p += random_vec(2e-3);
    const std::array<Vec3, 3> v{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    MembraneResult r;
    evaluate_membrane(g, mat, Vec3::Zero(), x, v, true, false, r);
    if (r.strain[0] < -1e-3 || r.strain[1] < -1e-3) ++compressed;
    const auto fd = weft::test::membrane_finite_differences(g, mat, x, v, 1e-8);
    EXPECT_LT(rel_err(r.force, -fd.energy_gradient), 1e-6) << "trial " << trial;
    EXPECT_LT(rel_err(r.stiffness, fd.force_jacobian), 1e-5) << "trial " << trial;
  }
  EXPECT_GT(compressed, 5) << "the test should reach compressed states";
}

TEST(MembraneElement, DefiniteStiffnessIsNegativeSemiDefiniteUnderCompression) {
  const Material mat = test_material();
  MembraneGeometry g;
  ASSERT_TRUE(make_membrane_geometry(Vec2(0, 0), Vec2(0.02, 0), Vec2(0, 0.02), g));
  int indefinite_exact = 0;
  for (int trial = 0; trial < 50; ++trial) {
    std::array<Vec3, 3> x{Vec3(0, 0, 0), Vec3(0.02 * uniform(0.7, 1.1), 0, 0), Vec3(0, 0.02 * uniform(0.7, 1.1), 0)};
    for (auto& p : x) p += random_vec(2e-3);
    std::array<Vec3, 3> v{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    MembraneResult exact, definite;
    evaluate_membrane(g, mat, Vec3::Zero(), x, v, true, false, exact);
    evaluate_membrane(g, mat, Vec3::Zero(), x, v, true, true, definite);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> es_d(definite.stiffness), es_e(exact.stiffness);
    EXPECT_LE(es_d.eigenvalues().maxCoeff(), 1e-9 * definite.stiffness.norm());
    if (es_e.eigenvalues().maxCoeff() > 1e-6 * exact.stiffness.norm()) ++indefinite_exact;
  }
  EXPECT_GT(indefinite_exact, 0) << "the test never reached a compressed (indefinite) state";
}

TEST(MembraneElement, PositivePartOfTwoByTwoMatchesEigenDecomposition) {
  // Random symmetric matrices of every sign pattern, including nearly diagonal ones whose
  // eigenvector is close to an axis, against clamping the eigenvalues at zero.
  for (int trial = 0; trial < 2000; ++trial) {
    const double scale = std::pow(10.0, uniform(-3, 3));
    double a = scale * uniform(-1, 1), b = scale * uniform(-1, 1);
    double c = scale * uniform(-1, 1) * (trial % 3 == 0 ? 1e-9 : 1.0);
    if (trial % 7 == 0) b = a;
    Mat2 A;
    A << a, c, c, b;
    Eigen::SelfAdjointEigenSolver<Mat2> es(A);
    const Mat2 expected = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() *
                          es.eigenvectors().transpose();
    project_positive_2x2(a, b, c);
    Mat2 P;
    P << a, c, c, b;
    EXPECT_LT((P - expected).cwiseAbs().maxCoeff(), 1e-14 * scale) << "trial " << trial << "\n" << A;
  }
}

TEST(MembraneElement, RigidMotionHasNoStrainAndNoForce) {
  const Material mat = test_material();
  MembraneGeometry g;
  ASSERT_TRUE(make_membrane_geometry(Vec2(0, 0), Vec2(0.03, 0.01), Vec2(0.005, 0.02), g));
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 w(0.3, -1.0, 2.0), c(1, 2, 3);
  std::array<Vec3, 3> x, v;
  const Vec2 p[3] = {Vec2(0, 0), Vec2(0.03, 0.01), Vec2(0.005, 0.02)};
  for (int i = 0; i < 3; ++i) {
    x[i] = R * Vec3(p[i].x(), p[i].y(), 0) + c;
    v[i] = w.cross(x[i] - c) + Vec3(0.1, 0.2, 0.3);  // rigid rotation + translation
  }
  MembraneResult r;
  evaluate_membrane(g, mat, Vec3(0.1, 0.1, 0.1), x, v, true, true, r);
  EXPECT_LT(r.strain.norm(), 1e-12);
  EXPECT_LT(r.force.norm(), 1e-10);
  EXPECT_NEAR(r.viscous_power, 0.0, 1e-12);
}

namespace {
// The energy 1/2 sum_ij Q_ij x_i . x_j of a bending stencil at the positions of its vertices.
double stencil_energy(const LinearBendingStencil& s, const std::array<Vec3, 4>& x) {
  double e = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) e += 0.5 * s.Q(i, j) * x[i].dot(x[j]);
  return e;
}
}  // namespace

// The hinge's measure R = sum alpha_i x_i vanishes on the flat rest shape and under rigid
// motion, and its stencil (the form the simulator assembles; its forces and Jacobians are
// checked against finite differences in tests/system/test_hinge_path.cpp) stores k_b |R|^2 / 2.
TEST(BendingElement, HingeMeasureVanishesAtRestAndTheStencilStoresItsSquare) {
  for (int trial = 0; trial < 20; ++trial) {
    const Vec2 c(0, 0), d(0.03 + uniform(0, 0.01), uniform(-0.005, 0.005));
    const Vec2 a(uniform(0.005, 0.025), uniform(0.01, 0.03)), b(uniform(0.005, 0.025), -uniform(0.01, 0.03));
    BendingGeometry g;
    ASSERT_TRUE(make_bending_geometry(a, b, c, d, 2e-5, 5e-5, g));
    const Vec2 pts[4] = {a, b, c, d};
    const Mat3 rot = Eigen::AngleAxisd(uniform(0, 3), random_vec(1.0).normalized()).toRotationMatrix();
    const Vec3 shift = random_vec(1.0);
    Vec3 R0 = Vec3::Zero();
    for (int i = 0; i < 4; ++i) R0 += g.alpha[i] * (rot * Vec3(pts[i].x(), pts[i].y(), 0) + shift);
    EXPECT_LT(R0.norm(), 1e-14);
    EXPECT_NEAR(g.alpha.sum(), 0.0, 1e-14);
    const LinearBendingStencil s = hinge_stencil({0, 1, 2, 3}, g);
    std::array<Vec3, 4> x;
    Vec3 R = Vec3::Zero();
    for (int i = 0; i < 4; ++i) {
      x[i] = Vec3(pts[i].x(), pts[i].y(), 0) + random_vec(0.005);
      R += g.alpha[i] * x[i];
    }
    EXPECT_NEAR(stencil_energy(s, x), 0.5 * g.stiffness * R.squaredNorm(), 1e-12 * g.stiffness * R.squaredNorm());
  }
}

TEST(BendingElement, StiffnessFollowsTheDirectionAcrossTheEdge) {
  // An edge along u bends the warp yarns; along v it bends the weft yarns.
  BendingGeometry along_u, along_v;
  ASSERT_TRUE(make_bending_geometry(Vec2(0.01, 0.01), Vec2(0.01, -0.01), Vec2(0, 0), Vec2(0.02, 0), 1e-5, 4e-5, along_u));
  ASSERT_TRUE(make_bending_geometry(Vec2(0.01, 0.01), Vec2(-0.01, 0.01), Vec2(0, 0.02), Vec2(0, 0), 1e-5, 4e-5, along_v));
  EXPECT_NEAR(along_u.stiffness / along_v.stiffness, 4.0, 1e-12);
}

namespace {
// Bending energy of the hinge elements of `mesh` rolled into a cylinder of curvature k about
// an axis along v (so the sheet bends along u), over the continuum value B k^2 / 2 per area.
double rolled_energy_ratio(const TriMesh& mesh, double B, double k) {
  std::vector<Vec3> x(mesh.num_vertices());
  for (int i = 0; i < mesh.num_vertices(); ++i) {
    const Vec2 p = mesh.pattern[i];
    x[i] = Vec3(std::sin(k * p.x()) / k, p.y(), (1 - std::cos(k * p.x())) / k);
  }
  // Each hinge stands for a third of its two triangles (the sheet less a boundary strip).
  auto height = [&](int tip, int c, int d) {
    const Vec2 e = mesh.pattern[d] - mesh.pattern[c], q = mesh.pattern[tip] - mesh.pattern[c];
    return std::abs(e.x() * q.y() - e.y() * q.x()) / e.norm();
  };
  double energy = 0, hinge_area = 0;
  for (const auto& s : interior_edge_stencils(mesh)) {
    BendingGeometry g;
    if (!make_bending_geometry(mesh.pattern[s[0]], mesh.pattern[s[1]], mesh.pattern[s[2]], mesh.pattern[s[3]], B, B, g))
      return std::nan("");  // fails the comparison
    const std::array<Vec3, 4> xs{x[s[0]], x[s[1]], x[s[2]], x[s[3]]};
    energy += stencil_energy(hinge_stencil({0, 1, 2, 3}, g), xs);
    const double cd = (mesh.pattern[s[3]] - mesh.pattern[s[2]]).norm();
    hinge_area += cd * (height(s[0], s[2], s[3]) + height(s[1], s[2], s[3])) / 6;
  }
  return energy / (0.5 * B * k * k * hinge_area);
}

// An equilateral mesh: rows sqrt(3)/2 h apart, odd rows shifted by h/2.
TriMesh equilateral_mesh(double h, int nu, int nv) {
  return make_grid(h * (nu - 1), std::sqrt(3.0) / 2 * h * (nv - 1), nu, nv, GridPattern::kShiftedRows);
}
}  // namespace

TEST(BendingElement, RolledSheetStoresTheContinuumCylinderEnergy) {
  // The rigidity B is defined by cylindrical bending; the hinge constant is calibrated on it.
  const double B = 2e-5, k = 4.0;
  EXPECT_NEAR(rolled_energy_ratio(make_grid(0.1, 0.1, 41, 41), B, k), 1.0, 0.01) << "square grid";
  EXPECT_NEAR(rolled_energy_ratio(equilateral_mesh(0.0025, 41, 41), B, k), 1.0, 0.01) << "equilateral mesh";
}

TEST(SpringElement, ForcesAndJacobiansMatchFiniteDifferences) {
  for (int trial = 0; trial < 20; ++trial) {
    const double k = uniform(10, 100), L0 = uniform(0, 1) < 0.2 ? 0.0 : uniform(0.5, 1.5), l = uniform(0.2, 2);
    const Vec3 x1 = random_vec(1), x2 = random_vec(1), v1 = random_vec(1), v2 = random_vec(1);
    SpringResult r;
    evaluate_spring(k, L0, 0.0, x1, x2, v1, v2, false, r);
    const double h = 1e-7;
    Mat3 Kfd, Dfd;
    Vec3 grad;
    for (int c = 0; c < 3; ++c) {
      Vec3 e = Vec3::Zero();
      e[c] = h;
      SpringResult rp, rm, rvp, rvm;
      evaluate_spring(k, L0, 0.0, x1 + e, x2, v1, v2, false, rp);
      evaluate_spring(k, L0, 0.0, x1 - e, x2, v1, v2, false, rm);
      evaluate_spring(k, L0, l, x1, x2, v1 + e, v2, false, rvp);
      evaluate_spring(k, L0, l, x1, x2, v1 - e, v2, false, rvm);
      grad[c] = (rp.energy - rm.energy) / (2 * h);
      Kfd.col(c) = (rp.force - rm.force) / (2 * h);
      Dfd.col(c) = (rvp.force - rvm.force) / (2 * h);
    }
    SpringResult rl;
    evaluate_spring(k, L0, l, x1, x2, v1, v2, false, rl);
    EXPECT_LT(rel_err(r.force, -grad), 1e-6);
    EXPECT_LT(rel_err(r.stiffness, Kfd), 1e-6);
    EXPECT_LT(rel_err(rl.damping, Dfd), 1e-6);
  }
}
