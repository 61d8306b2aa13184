// The cloth's fused step assembly (forces, step matrix M-free part -ck K - cd D, and K w in
// one pass, bending applied per block slot) must equal the reference built from the
// per-element Jacobians (System::assemble_step via evaluate), and the membrane's K w,
// formed as a directional derivative, must equal its 9x9 stiffness times w.
#include <gtest/gtest.h>

#include <random>

#include "damping/adaptive.hpp"
#include "elements/membrane.hpp"
#include "mesh/mesh.hpp"
#include "system/cloth.hpp"

using namespace weft;

namespace {

std::mt19937 rng(777);
double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
Vec3 random_vec(double s) { return Vec3(uniform(-s, s), uniform(-s, s), uniform(-s, s)); }

Material anisotropic_material() {
  Material m;
  m.weft = StressCurve::linear(300);
  m.warp = StressCurve::linear(120);
  m.shear = StressCurve::linear(15);
  m.poisson_ratio = 0.3;
  m.bending_rigidity_weft_Nm = 2e-4;
  m.bending_rigidity_warp_Nm = 5e-5;
  m.viscosity_Ns_m = 1e-3;
  return m;
}

double max_abs(const VecX& a) { return a.cwiseAbs().maxCoeff(); }

}  // namespace

TEST(MembraneElement, StiffnessTimesVectorEqualsExpandedStiffness) {
  const Material mat = anisotropic_material();
  for (int trial = 0; trial < 20; ++trial) {
    MembraneGeometry g;
    const Vec2 pa(0, 0), pb(0.02 + uniform(0, 0.01), uniform(-0.005, 0.005)), pc(uniform(0, 0.01), 0.02);
    ASSERT_TRUE(make_membrane_geometry(pa, pb, pc, g));
    // Stretched and compressed states, so the projection of the stress matrix is exercised.
    const double s = uniform(0.8, 1.2);
    std::array<Vec3, 3> x{Vec3(pa.x(), pa.y(), 0), Vec3(s * pb.x(), pb.y(), 0), Vec3(pc.x(), s * pc.y(), 0)};
    std::array<Vec3, 3> v, w, kw;
    for (int k = 0; k < 3; ++k) {
      x[k] += random_vec(3e-3);
      v[k] = random_vec(0.5);
      w[k] = random_vec(1.0);
    }
    MembraneResult r;
    evaluate_membrane(g, mat, Vec3(0.01, 0.02, 0.005), x, v, true, true, r, true);
    r.jacobian.stiffness_times(g, w, kw);
    Eigen::Matrix<double, 9, 1> wv, kv;
    for (int k = 0; k < 3; ++k) {
      wv.segment<3>(3 * k) = w[k];
      kv.segment<3>(3 * k) = kw[k];
    }
    const Eigen::Matrix<double, 9, 1> expected = r.stiffness * wv;
    EXPECT_LT((kv - expected).norm(), 1e-12 * (r.stiffness.norm() * wv.norm())) << "trial " << trial;
  }
}

namespace {

// `nu` x `nv` vertices: 7 x 6 has 60 triangles, which linear curves assemble four at a
// time; 6 x 4 has 30, the last two of them one at a time.
void expect_fused_equals_reference(const Material& material, BendingModel bending, int nu = 7, int nv = 6) {
  const ClothModel model =
      build_cloth_model(make_grid(0.2, 0.15, nu, nv), material, Vec3(0, -9.81, 0), {0, nu - 1}, bending);
  ClothSystem system(model, DampingSettings{0.05});
  VecX x = model.initial_positions(), v(x.size()), w(x.size());
  for (int i = 0; i < model.num_vertices(); ++i) {
    node(x, i) += random_vec(4e-3);
    node(v, i) = random_vec(0.3);
    node(w, i) = random_vec(0.01);
  }
  system.begin_step(x, v, 0.01);
  StepAssembly fused, reference;
  fused.ck = reference.ck = 2.5e-5;
  fused.cd = reference.cd = 5e-3;
  // A matrix left over from another step must not leak into the assembly.
  fused.matrix.reset(model.pattern);
  for (auto& b : fused.matrix.block) b.setConstant(123.0);
  system.assemble_step(x, v, w, fused);
  system.System::assemble_step(x, v, w, reference);

  EXPECT_LT(max_abs(fused.force - reference.force), 1e-12 * max_abs(reference.force));
  EXPECT_LT(max_abs(fused.stiffness_times_w - reference.stiffness_times_w),
            1e-12 * max_abs(reference.stiffness_times_w));
  EXPECT_NEAR(fused.elastic_energy, reference.elastic_energy, 1e-12 * std::abs(reference.elastic_energy));
  EXPECT_NEAR(fused.gravity_energy, reference.gravity_energy, 1e-12 * std::abs(reference.gravity_energy));
  EXPECT_NEAR(fused.viscous_power, reference.viscous_power, 1e-12 * std::abs(reference.viscous_power));
  ASSERT_LT(reference.viscous_power, 0.0) << "the state must dissipate for the comparison to mean something";
  const MatX a = fused.matrix.to_dense(), b = reference.matrix.to_dense();
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
  // The bending and damping parts are present: the matrix is not only the membranes' K.
  EXPECT_GT(system.bending_damping().front(), 0.0);
  // The separate viscous-power pass agrees with the assembly's.
  EXPECT_NEAR(system.viscous_power(x, v), reference.viscous_power, 1e-12 * std::abs(reference.viscous_power));
  // The power after the solve, at the assembly's positions and another velocity: with the
  // deformation gradients kept from the assembly it is the separate pass's, bit for bit.
  VecX mean_v(x.size());
  for (int i = 0; i < model.num_vertices(); ++i) node(mean_v, i) = random_vec(0.3);
  const double separate = system.viscous_power(x, mean_v);
  ASSERT_LT(separate, 0.0);
  EXPECT_EQ(system.step_viscous_power(x, mean_v, fused), separate);
  EXPECT_EQ(fused.element_data.empty(), !material.weft.is_linear() || model.membranes.size() < 4)
      << "the batched pass (linear curves) keeps the gradients, the others keep nothing";
  // Assembling again (the blocks now hold the previous result) gives the same matrix.
  system.assemble_step(x, v, w, fused);
  EXPECT_LT((fused.matrix.to_dense() - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
}

}  // namespace

TEST(ClothAssembly, FusedStepAssemblyEqualsElementJacobianReference) {
  expect_fused_equals_reference(anisotropic_material(), BendingModel::kHinge);
}

TEST(ClothAssembly, FusedStepAssemblyEqualsReferenceWithTrianglesLeftOverFromBatches) {
  expect_fused_equals_reference(anisotropic_material(), BendingModel::kHinge, 6, 4);
}

TEST(ClothAssembly, FusedStepAssemblyEqualsReferenceForPlateBending) {
  expect_fused_equals_reference(anisotropic_material(), BendingModel::kPlate);
}

TEST(ClothAssembly, FusedStepAssemblyEqualsReferenceForNonlinearCurves) {
  // Tabulated (spline) curves: the tangent moduli vary with the strain.
  Material m = anisotropic_material();
  m.weft = StressCurve::tabulated({-0.05, 0.0, 0.02, 0.05}, {-2.0, 0.0, 5.0, 30.0});
  m.warp = StressCurve::tabulated({-0.05, 0.0, 0.03, 0.06}, {-1.0, 0.0, 2.0, 12.0});
  m.shear = StressCurve::odd_symmetric({0.0, 0.05, 0.2}, {0.0, 0.4, 3.0});
  expect_fused_equals_reference(m, BendingModel::kHinge);
}

TEST(ClothAssembly, DampingStatisticsOfLinearCurvesEqualPerElementValues) {
  // With linear curves the viscosity and the stiffness factors do not depend on the state:
  // the statistics gathered over steps must be those of the per-element values, every step.
  const ClothModel model =
      build_cloth_model(make_grid(0.2, 0.15, 7, 6), anisotropic_material(), Vec3(0, -9.81, 0), {0, 6});
  const double zeta = 0.3, eta0 = model.materials.front().viscosity_Ns_m;
  ClothSystem system(model, DampingSettings{zeta});
  LogStatistics kappa, lambda, added;
  long raised = 0;
  VecX x = model.initial_positions(), v = VecX::Zero(x.size());
  const double dts[] = {0.01, 0.01, 0.002, 0.01};
  for (double dt : dts) {
    for (int i = 0; i < model.num_vertices(); ++i) node(x, i) += random_vec(1e-3);
    system.begin_step(x, v, dt);
    for (size_t t = 0; t < model.membranes.size(); ++t) {
      const auto& g = model.membranes[t];
      const Vec3& S = model.membrane_mass_sums[t];
      const Vec3 E = membrane_tangent_moduli(model.materials.front(), Vec3::Zero());
      const Vec3 eta = Vec3::Constant(eta0).cwiseMax(membrane_required_viscosity(g.area, E, S, zeta));
      EXPECT_EQ(system.membrane_viscosity()[t], eta);
      int mode;
      kappa.add(membrane_kappa(g.area, E, S, dt).maxCoeff(&mode));
      lambda.add(membrane_lambda(g.area, eta, S, dt)[mode]);
      const double a = (eta - Vec3::Constant(eta0)).maxCoeff();
      if (a > 0) {
        ++raised;
        added.add(a);
      }
    }
  }
  const DampingStatistics& s = system.statistics();
  EXPECT_EQ(s.element_steps, static_cast<long>(4 * model.membranes.size()));
  EXPECT_EQ(s.raised_element_steps, raised);
  EXPECT_GT(raised, 0);
  const std::pair<const LogStatistics*, const LogStatistics*> pairs[] = {
      {&s.membrane_kappa, &kappa}, {&s.membrane_lambda, &lambda}, {&s.added_viscosity, &added}};
  for (const auto& [got, expected] : pairs) {
    EXPECT_EQ(got->count(), expected->count());
    EXPECT_EQ(got->min(), expected->min());
    EXPECT_EQ(got->max(), expected->max());
    EXPECT_EQ(got->median(), expected->median());
    EXPECT_NEAR(got->mean(), expected->mean(), 1e-14 * expected->mean());
  }
}

TEST(LogStatistics, MedianWithinHalfABinAndExactExtremes) {
  LogStatistics s;
  std::vector<double> values;
  for (int k = 0; k < 1001; ++k) values.push_back(std::pow(10.0, uniform(-6, 6)));
  for (double value : values) s.add(value);
  s.add(0.0);  // ignored: not positive
  s.add(std::numeric_limits<double>::quiet_NaN());
  std::sort(values.begin(), values.end());
  EXPECT_EQ(s.count(), 1001);
  EXPECT_EQ(s.min(), values.front());
  EXPECT_EQ(s.max(), values.back());
  // Bins are 1/128 of an octave: the centre is within 2^(1/256) - 1 (0.28%) of any value in it.
  EXPECT_NEAR(s.median() / values[500], 1.0, 0.0028);
  LogStatistics t;
  t.merge(s);
  t.merge(s);
  EXPECT_EQ(t.count(), 2002);
  EXPECT_EQ(t.median(), s.median());
}

// Forces and energies alone never allocate the Jacobian matrices (a simulation's energy
// evaluations and the explicit integrators); the first evaluation that asks for them does,
// and gets the same values as one on matrices set up beforehand.
TEST(ClothSystem, EvaluationAllocatesJacobiansOnlyWhenAsked) {
  const ClothModel model =
      build_cloth_model(make_grid(0.2, 0.15, 7, 6), anisotropic_material(), Vec3(0, -9.81, 0), {0, 6});
  ClothSystem system(model, DampingSettings{0.05});
  VecX x = model.initial_positions(), v(x.size());
  for (int i = 0; i < model.num_vertices(); ++i) {
    node(x, i) += random_vec(4e-3);
    node(v, i) = random_vec(0.3);
  }
  system.begin_step(x, v, 0.01);
  Evaluation lazy, prepared;
  system.evaluate(x, v, false, lazy);
  EXPECT_EQ(lazy.force.size(), x.size());
  EXPECT_TRUE(lazy.stiffness.block.empty());
  EXPECT_TRUE(lazy.damping.block.empty());
  system.evaluate(x, v, true, lazy);
  system.prepare(prepared);
  system.evaluate(x, v, true, prepared);
  ASSERT_EQ(lazy.stiffness.block.size(), prepared.stiffness.block.size());
  EXPECT_EQ((lazy.stiffness.to_dense() - prepared.stiffness.to_dense()).norm(), 0.0);
  EXPECT_EQ((lazy.damping.to_dense() - prepared.damping.to_dense()).norm(), 0.0);
  EXPECT_GT(lazy.stiffness.to_dense().norm(), 0.0);
  EXPECT_EQ((lazy.force - prepared.force).norm(), 0.0);
}
