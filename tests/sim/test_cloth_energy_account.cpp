// The energy account of a cloth run, kept here from the definitions (docs/method.md 6): kinetic
// energy from the masses, bending energy and the bending viscous forces from the stencils'
// Q and damping gamma, gravity from the weights. The membrane has no stiffness and no
// viscosity, so the forces are linear in the state (F = m g - Q x - gamma Q v): Implicit
// Midpoint applies them at the mean of each step's two states, and its balance must close.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

Scene hanging_sheet() {
  Scene s;
  s.cloth.grid = GridSpec{0.3, 0.3, 7, 7};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);  // horizontal, falling under gravity
  s.cloth.pin_grid_nodes = {{0, 0}, {-1, 0}};
  s.cloth.material.weft = StressCurve::linear(0);
  s.cloth.material.warp = StressCurve::linear(0);
  s.cloth.material.shear = StressCurve::linear(0);
  s.cloth.material.viscosity_Ns_m = 0;
  s.cloth.material.bending_rigidity_weft_Nm = 2e-4;
  s.cloth.material.bending_rigidity_warp_Nm = 1e-4;
  set_method(s, "implicit-midpoint", std::nullopt, "test");
  s.damping_ratio = 0.3;
  s.integrator.dt = 0.005;
  s.frame_interval = 0.005;
  s.duration = 0.2;
  s.integrator.cg_tolerance = 1e-12;
  s.integrator.ssor_single_precision = false;
  return s;
}

struct Account {
  double kinetic = 0, bending = 0, gravity = 0;
  double total() const { return kinetic + bending + gravity; }
};

Account account(const Simulation& sim, const VecX& x0) {
  const ClothModel& m = sim.core().model();
  const State& s = sim.core().state();
  Account a;
  for (int i = 0; i < m.num_vertices(); ++i) {
    a.kinetic += 0.5 * m.mass[i] * node(s.v, i).squaredNorm();
    a.gravity -= m.mass[i] * m.gravity.dot(node(s.x, i) - node(x0, i));
  }
  for (const auto& st : m.bending) {
    const auto k = static_cast<Eigen::Index>(st.vertices.size());
    for (Eigen::Index p = 0; p < k; ++p)
      for (Eigen::Index q = 0; q < k; ++q)
        a.bending += 0.5 * st.Q(p, q) * node(s.x, st.vertices[p]).dot(node(s.x, st.vertices[q]));
  }
  return a;
}

/// Work done against the stencils' damping forces -gamma Q u while the nodes move by dx.
double bending_viscous_work(const Simulation& sim, const VecX& dx, const VecX& u) {
  const ClothModel& m = sim.core().model();
  double w = 0;
  for (size_t e = 0; e < m.bending.size(); ++e) {
    const auto& st = m.bending[e];
    const auto k = static_cast<Eigen::Index>(st.vertices.size());
    for (Eigen::Index p = 0; p < k; ++p)
      for (Eigen::Index q = 0; q < k; ++q)
        w += sim.core().system().bending_damping()[e] * st.Q(p, q) * node(dx, st.vertices[p]).dot(node(u, st.vertices[q]));
  }
  return w;
}

}  // namespace

TEST(EnergyAccount, ImplicitMidpointClosesTheBalanceOfALinearCloth) {
  Simulation sim(hanging_sheet());
  const VecX x0 = sim.core().state().x;
  const Account a0 = account(sim, x0);
  double work = 0, worst_step = 0;
  const double dt = sim.scene().integrator.dt;
  for (int k = 1; k <= 40; ++k) {
    const State before = sim.core().state();
    const Account e_before = account(sim, x0);
    sim.advance_to(k * dt);
    const State& s = sim.core().state();
    const double w = bending_viscous_work(sim, s.x - before.x, 0.5 * (before.v + s.v));
    work += w;
    const Account e = account(sim, x0);
    worst_step = std::max(worst_step, std::abs(e.total() - e_before.total() + w));
    // What the simulation reports is what is computed here.
    const EnergyRow r = sim.energies();
    const double scale = std::abs(e.gravity) + e.kinetic + e.bending + 1e-12;
    EXPECT_NEAR(r.kinetic, e.kinetic, 1e-12 * scale) << "step " << k;
    EXPECT_NEAR(r.elastic, e.bending, 1e-12 * scale) << "step " << k;
    EXPECT_NEAR(r.gravity, e.gravity, 1e-12 * scale) << "step " << k;
  }
  ASSERT_EQ(sim.core().statistics().cg_failures, 0);
  const Account a = account(sim, x0);
  RecordProperty("viscous_work_J", testing::PrintToString(work));
  RecordProperty("bending_J", testing::PrintToString(a.bending));
  ASSERT_GT(a.bending, 0);
  ASSERT_GT(work, 0.1 * a.bending) << "the bending damping should matter here";
  EXPECT_NEAR(sim.core().state().viscous_dissipated, work, 1e-9 * work);
  EXPECT_LT(worst_step, 1e-8 * work);
  EXPECT_LT(std::abs(a.total() - a0.total() + work), 1e-7 * work);
}
