// The plate bending element: exact energy for quadratic height fields (bends, spheres,
// twists) on any mesh, rigid-motion invariance, and forces against finite differences.
#include <gtest/gtest.h>

#include <random>

#include "elements/plate_bending.hpp"
#include "system/cloth.hpp"

using namespace weft;

namespace {

double bending_energy(const std::vector<LinearBendingStencil>& stencils, const VecX& x) {
  double e = 0;
  for (const auto& s : stencils)
    for (size_t i = 0; i < s.vertices.size(); ++i)
      for (size_t j = 0; j < s.vertices.size(); ++j)
        e += 0.5 * s.Q(i, j) * node(x, s.vertices[i]).dot(node(x, s.vertices[j]));
  return e;
}

// A grid with jittered interior vertices: an irregular mesh.
TriMesh irregular_mesh(double size, int n, unsigned seed) {
  TriMesh m = make_grid(size, size, n, n);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-0.25, 0.25);
  const double h = size / (n - 1);
  for (int j = 1; j + 1 < n; ++j)
    for (int i = 1; i + 1 < n; ++i) {
      const int k = j * n + i;
      m.pattern[k] += Vec2(U(rng) * h, U(rng) * h);
      m.positions.row(k) = Vec3(m.pattern[k].x(), m.pattern[k].y(), 0).transpose();
    }
  return m;
}

}  // namespace

TEST(PlateBending, ExactEnergyForQuadraticHeightFieldsOnIrregularMeshes) {
  const double Bu = 2e-5, Bv = 5e-5, Bt = std::sqrt(Bu * Bv), size = 0.2;
  const TriMesh mesh = irregular_mesh(size, 9, 4);
  const auto stencils = plate_bending_stencils(mesh, Bu, Bv);
  double area = 0;
  for (const auto& t : mesh.triangles) {
    const Vec2 e1 = mesh.pattern[t[1]] - mesh.pattern[t[0]], e2 = mesh.pattern[t[2]] - mesh.pattern[t[0]];
    area += 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
  }
  // Cylinders along u and v, a sphere, a saddle and a twist: each second-derivative mode.
  const double cases[][3] = {{1, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, -1}, {0, 1, 0}, {0.3, -0.7, 0.5}};
  for (const auto& c : cases) {
    const double a = c[0], b = c[1], d = c[2];
    VecX x(3 * mesh.num_vertices());
    for (int i = 0; i < mesh.num_vertices(); ++i) {
      const Vec2 p = mesh.pattern[i];
      node(x, i) = Vec3(p.x(), p.y(), 0.5 * (a * p.x() * p.x() + 2 * b * p.x() * p.y() + d * p.y() * p.y()));
    }
    const double expected = 0.5 * area * (Bu * a * a + Bv * d * d + 2 * Bt * b * b);
    EXPECT_NEAR(bending_energy(stencils, x), expected, 1e-6 * expected) << a << " " << b << " " << d;
  }
}

TEST(PlateBending, RigidMotionsAndLinearFieldsStoreNoEnergy) {
  const TriMesh mesh = irregular_mesh(0.2, 7, 9);
  const auto stencils = plate_bending_stencils(mesh, 1e-5, 1e-5);
  const Mat3 R = Eigen::AngleAxisd(1.1, Vec3(0.2, -1, 0.4).normalized()).toRotationMatrix();
  VecX x(3 * mesh.num_vertices());
  for (int i = 0; i < mesh.num_vertices(); ++i)
    node(x, i) = R * Vec3(mesh.pattern[i].x(), mesh.pattern[i].y(), 0) + Vec3(0.01, 0.02, 0.03);
  // Against the energy of a unit curvature (1/m) over the 0.2 m sheet: zero to rounding.
  EXPECT_LT(bending_energy(stencils, x), 1e-6 * 0.5 * 1e-5 * 0.04);
  for (const auto& s : stencils) {
    EXPECT_NEAR(s.measures.rowwise().sum().cwiseAbs().maxCoeff(), 0.0, 1e-6 * s.measures.cwiseAbs().maxCoeff());
    Eigen::SelfAdjointEigenSolver<MatX> es(s.Q);
    EXPECT_GE(es.eigenvalues().minCoeff(), -1e-9 * es.eigenvalues().maxCoeff());
  }
}

TEST(PlateBending, ClothForcesAndJacobiansMatchFiniteDifferences) {
  Material mat;
  mat.bending_rigidity_weft_Nm = 3e-5;
  mat.bending_rigidity_warp_Nm = 1e-5;
  mat.weft = mat.warp = mat.shear = StressCurve::linear(0.0);  // bending alone
  const ClothModel model = build_cloth_model(irregular_mesh(0.1, 5, 2), mat, Vec3::Zero(), {}, BendingModel::kPlate);
  ClothSystem system(model, DampingSettings{0.05});
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-0.005, 0.005);
  VecX x = model.initial_positions(), v(x.size());
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    x[k] += U(rng);
    v[k] = 100 * U(rng);
  }
  system.begin_step(x, v, 0.01);  // sets the bending damping
  Evaluation e;
  system.prepare(e);
  system.evaluate(x, v, true, e);
  const MatX K = e.stiffness.to_dense(), D = e.damping.to_dense();
  const double h = 1e-6;
  Evaluation ep, em;
  system.prepare(ep);
  system.prepare(em);
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    VecX xp = x, xm = x, vp = v, vm = v;
    xp[k] += h;
    xm[k] -= h;
    system.evaluate(xp, v, false, ep);
    system.evaluate(xm, v, false, em);
    const VecX dfdx = (ep.force - em.force) / (2 * h);
    // Elastic force = total force minus the (linear) damping force D v.
    const double elastic_force = e.force[k] - (D * v)[k];
    EXPECT_NEAR(-(ep.elastic_energy - em.elastic_energy) / (2 * h), elastic_force,
                1e-6 * std::max(1e-9, e.force.cwiseAbs().maxCoeff()));
    EXPECT_LT((dfdx - K.col(k)).norm(), 1e-6 * std::max(1e-9, K.norm())) << k;
    vp[k] += h;
    vm[k] -= h;
    system.evaluate(x, vp, false, ep);
    system.evaluate(x, vm, false, em);
    EXPECT_LT(((ep.force - em.force) / (2 * h) - D.col(k)).norm(), 1e-6 * std::max(1e-12, D.norm())) << k;
  }
}
