// The hinge bending path the simulator runs: stencils summed per block slot in ClothSystem
// (evaluate, assemble_step, the viscous power of the energy account). Its energy must be the
// sum of the hinge elements k_b |R|^2 / 2, R = sum alpha_i x_i (the constant is tested against
// the continuum cylinder in tests/elements/test_elements.cpp), over the interior edges, its
// forces minus the energy's gradient, its Jacobians those of the forces, and its viscous
// power the viscous forces' power. The membrane is given no stiffness
// and no viscosity, so that everything measured here is bending.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "elements/bending.hpp"
#include "mesh/mesh.hpp"
#include "system/cloth.hpp"

using namespace weft;

namespace {

Material bending_only(double rigidity_weft, double rigidity_warp) {
  Material m;
  m.weft = StressCurve::linear(0);
  m.warp = StressCurve::linear(0);
  m.shear = StressCurve::linear(0);
  m.viscosity_Ns_m = 0;
  m.bending_rigidity_weft_Nm = rigidity_weft;
  m.bending_rigidity_warp_Nm = rigidity_warp;
  return m;
}

/// A 5 x 4 vertex grid of 2 cm cells (with a shifted-rows option for irregular hinges),
/// no gravity, no pins.
ClothModel hinge_model(GridPattern pattern) {
  return build_cloth_model(make_grid(0.08, 0.06, 5, 4, pattern), bending_only(3e-5, 1e-5), Vec3::Zero(), {});
}

/// A bent, moving state near the flat rest shape.
void bent_state(const ClothModel& m, unsigned seed, VecX& x, VecX& v) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  x = m.initial_positions();
  v = VecX(x.size());
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    x[k] += 4e-3 * u(rng);
    v[k] = 0.3 * u(rng);
  }
}

MatX dense(const BlockMatrix& a) {
  const BlockPattern& p = *a.pattern;
  MatX d = MatX::Zero(3 * p.num_nodes(), 3 * p.num_nodes());
  for (int i = 0; i < p.num_nodes(); ++i)
    for (int s = p.row_start()[i]; s < p.row_start()[i + 1]; ++s) d.block<3, 3>(3 * i, 3 * p.column()[s]) = a.block[s];
  return d;
}

double rel_err(const MatX& a, const MatX& b) { return (a - b).norm() / std::max(b.norm(), 1e-300); }

}  // namespace

TEST(HingePath, EnergyIsTheSumOfTheHingeElementsOverTheInteriorEdges) {
  // The interior edges are found here from the triangles (each edge shared by two), and each
  // hinge built from the pattern with make_bending_geometry and its energy k_b |R|^2 / 2 taken.
  for (GridPattern pattern : {GridPattern::kAlternatingDiagonals, GridPattern::kShiftedRows}) {
    const ClothModel m = hinge_model(pattern);
    ClothSystem sys(m, DampingSettings{});
    VecX x, v;
    bent_state(m, 11, x, v);
    std::map<std::pair<int, int>, std::vector<int>> tips;  // edge (low, high) -> opposite vertices
    for (const auto& t : m.mesh.triangles)
      for (int k = 0; k < 3; ++k) {
        const int a = t[k], b = t[(k + 1) % 3];
        tips[{std::min(a, b), std::max(a, b)}].push_back(t[(k + 2) % 3]);
      }
    double expected = 0;
    int hinges = 0;
    for (const auto& [edge, opposite] : tips) {
      if (opposite.size() != 2) continue;
      const int ids[4] = {opposite[0], opposite[1], edge.first, edge.second};
      BendingGeometry g;
      ASSERT_TRUE(make_bending_geometry(m.mesh.pattern[ids[0]], m.mesh.pattern[ids[1]], m.mesh.pattern[ids[2]],
                                        m.mesh.pattern[ids[3]], 3e-5, 1e-5, g));
      Vec3 R = Vec3::Zero();
      for (int k = 0; k < 4; ++k) R += g.alpha[k] * node(x, ids[k]);
      expected += 0.5 * g.stiffness * R.squaredNorm();
      ++hinges;
    }
    ASSERT_EQ(static_cast<size_t>(hinges), m.bending.size());
    Evaluation e;
    sys.evaluate(x, v, false, e);
    ASSERT_GT(expected, 0);
    EXPECT_NEAR(e.elastic_energy, expected, 1e-12 * expected);
  }
}

TEST(HingePath, ForcesJacobiansAndViscousPowerMatchFiniteDifferences) {
  for (GridPattern pattern : {GridPattern::kAlternatingDiagonals, GridPattern::kShiftedRows}) {
    const ClothModel m = hinge_model(pattern);
    // Adaptive damping gives every stencil a damping force -gamma Q v.
    ClothSystem sys(m, DampingSettings{0.2, 0.0});
    sys.begin_step(m.initial_positions(), VecX::Zero(3 * m.num_vertices()), 0.01);
    VecX x, v;
    bent_state(m, 23, x, v);
    const VecX rest = VecX::Zero(x.size());
    const Eigen::Index n = x.size();
    Evaluation e, moving;
    sys.evaluate(x, rest, true, e);
    sys.evaluate(x, v, true, moving);
    // The bending energy is quadratic in x and the forces linear in x and v: central
    // differences are exact up to rounding.
    const double h = 1e-5;
    VecX grad(n);
    MatX K(n, n), D(n, n);
    Evaluation p, q;
    for (Eigen::Index k = 0; k < n; ++k) {
      VecX xp = x, xm = x;
      xp[k] += h;
      xm[k] -= h;
      sys.evaluate(xp, rest, false, p);
      sys.evaluate(xm, rest, false, q);
      grad[k] = (p.elastic_energy - q.elastic_energy) / (2 * h);
      K.col(k) = (p.force - q.force) / (2 * h);
      VecX vp = v, vm = v;
      vp[k] += h;
      vm[k] -= h;
      sys.evaluate(x, vp, false, p);
      sys.evaluate(x, vm, false, q);
      D.col(k) = (p.force - q.force) / (2 * h);
    }
    ASSERT_GT(grad.norm(), 0);
    ASSERT_GT(D.norm(), 0) << "the stencils should carry damping";
    EXPECT_LT(rel_err(e.force, -grad), 1e-6);
    EXPECT_LT(rel_err(dense(e.stiffness), K), 1e-6);
    EXPECT_LT(rel_err(dense(moving.damping), D), 1e-6);
    // The viscous force is what v adds to the force; its power is that force . v, the same
    // from evaluate, from viscous_power and from the step's own (step_viscous_power).
    const double power = (moving.force - e.force).dot(v);
    ASSERT_LT(power, 0);
    EXPECT_NEAR(moving.viscous_power, power, 1e-9 * std::abs(power));
    EXPECT_NEAR(sys.viscous_power(x, v), power, 1e-9 * std::abs(power));
    // The step path: A = -cd D - ck K and K w from the fused assembly, against the
    // differences; its force the evaluation's; its viscous power the same.
    StepAssembly step;
    step.matrix.reset(m.pattern);
    step.ck = 2.5e-5;
    step.cd = 5e-3;
    const VecX w = 0.01 * v;
    sys.assemble_step(x, v, w, step);
    EXPECT_LT(rel_err(step.force, moving.force), 1e-12);
    EXPECT_LT(rel_err(dense(step.matrix), -step.cd * D - step.ck * K), 1e-6);
    EXPECT_LT(rel_err(step.stiffness_times_w, K * w), 1e-6);
    EXPECT_NEAR(sys.step_viscous_power(x, v, step), power, 1e-9 * std::abs(power));
  }
}
