#pragma once
// The linear system of one Implicit Midpoint step of the benchmark cloth (bench/bench_step.cpp):
// 1 m x 1 m, n x n vertices, pinned at two corners, dt = 5 ms, cotton-like linear material;
// or of another scene's cloth.
// A = M - cd D - ck K and b are assembled as the integrator does (docs/method.md 1-2).
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "sim/simulation_core.hpp"

namespace weft::test {

struct ClothStepProblem {
  std::unique_ptr<Simulation> sim;
  StepAssembly step;  ///< step.matrix is A
  VecX rhs;           ///< b
  VecX guess;         ///< the integrator's warm start (previous dv, or zero)
  const std::vector<char>& pinned() const { return sim->core().system().pinned(); }
  const BlockMatrix& matrix() const { return step.matrix; }
};

inline Scene cloth_step_scene(int n) {
  Scene s;
  s.duration = 1.0;
  s.frame_interval = 0.005;
  s.cloth.grid = GridSpec{1.0, 1.0, n, n};
  s.cloth.rotation_deg = Vec3(-90, 0, 0);
  s.cloth.pin_grid_nodes = {{0, 0}, {-1, 0}};
  s.cloth.material.surface_density_kg_m2 = 0.15;
  s.cloth.material.weft = StressCurve::linear(100);
  s.cloth.material.warp = StressCurve::linear(100);
  s.cloth.material.shear = StressCurve::linear(10);
  s.cloth.material.bending_rigidity_weft_Nm = s.cloth.material.bending_rigidity_warp_Nm = 1e-4;
  set_method(s, "implicit-midpoint", std::nullopt, "test");
  s.integrator.dt = 0.005;
  s.integrator.cg_tolerance = 1e-6;
  return s;
}

/// The same cloth read from the OBJ at `obj_path` (already laid out horizontally: no turn),
/// pinned at the vertices `pins` instead of the grid's corners.
inline Scene cloth_step_scene_from_obj(int n, const std::string& obj_path, std::vector<int> pins) {
  Scene s = cloth_step_scene(n);
  s.cloth.grid.reset();
  s.cloth.obj_path = obj_path;
  s.cloth.rotation_deg = Vec3::Zero();
  s.cloth.pin_grid_nodes.clear();
  s.cloth.pin_vertices = std::move(pins);
  return s;
}

/// Lets the scene's cloth move for `settle_time` seconds, then assembles the next step's
/// system.
inline void make_cloth_step_problem(const Scene& scene, double settle_time, ClothStepProblem& p) {
  p.sim = std::make_unique<Simulation>(scene);
  if (settle_time > 0) p.sim->advance_to(settle_time);
  State& st = p.sim->core().state();
  System& sys = p.sim->core().system();
  const double dt = p.sim->scene().integrator.dt, alpha = 0.5;
  sys.begin_step(st.x, st.v, dt);
  p.step.ck = alpha * alpha * dt * dt;
  p.step.cd = alpha * dt;
  const VecX w = dt * st.v;
  sys.assemble_step(st.x, st.v, w, p.step);
  p.rhs = dt * p.step.force + alpha * dt * p.step.stiffness_times_w;
  const VecX& m = sys.node_mass();
  for (int i = 0; i < sys.num_nodes(); ++i)
    p.step.matrix.block[sys.pattern().diagonal_slot(i)].diagonal().array() += m[i];
  p.guess = st.dv_prev.size() == 3 * sys.num_nodes() ? st.dv_prev : VecX::Zero(3 * sys.num_nodes());
}

/// The same for the benchmark cloth at n x n vertices.
inline void make_cloth_step_problem(int n, double settle_time, ClothStepProblem& p) {
  make_cloth_step_problem(cloth_step_scene(n), settle_time, p);
}

/// Perturbs one off-diagonal block between free nodes that is a multiple of I3 (a hinge
/// coupling) and its transpose, keeping A symmetric; returns false when there is none.
inline bool break_one_scalar_block(BlockMatrix& A, const std::vector<char>& fixed) {
  const auto& rs = A.pattern->row_start();
  const auto& col = A.pattern->column();
  for (int i = 0; i < A.pattern->num_nodes(); ++i)
    for (int s = rs[i]; s < rs[i + 1] && col[s] < i; ++s) {
      const Mat3& b = A.block[s];
      if (fixed[i] || fixed[col[s]] || !(b - b(0, 0) * Mat3::Identity()).isZero(0.0)) continue;
      A.block[s](0, 1) += 1e-3;
      A.block[A.pattern->slot(col[s], i)](1, 0) += 1e-3;
      A.constants_changed();  // the block may be one of A's constant slots
      return true;
    }
  return false;
}

}  // namespace weft::test
