#include "analysis/static_equilibrium.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>

namespace weft {

namespace {

struct Evaluated {
  VecX force;     // internal + load_factor * gravity
  double energy;  // elastic + load_factor * gravitational potential
};

// The cloth system adds full gravity; the load factor scales its share of force and energy.
Evaluated evaluate_loaded(ClothSystem& system, const VecX& x, const VecX& v, double load_factor,
                          bool jacobians, Evaluation& eval) {
  system.evaluate(x, v, jacobians, eval);
  const ClothModel& model = system.model();
  Evaluated out{eval.force, eval.elastic_energy + load_factor * eval.gravity_energy};
  if (load_factor != 1.0)
    for (int i = 0; i < model.num_vertices(); ++i)
      node(out.force, i) -= (1.0 - load_factor) * model.mass[i] * model.gravity;
  return out;
}

double free_max_abs(const VecX& f, const std::vector<char>& fixed) {
  double m = 0;
  for (Eigen::Index k = 0; k < f.size(); ++k)
    if (!fixed[k]) m = std::max(m, std::abs(f[k]));
  return m;
}

}  // namespace

StaticSolveResult solve_static_equilibrium(ClothSystem& system, VecX& x,
                                           const std::vector<char>& fixed_coordinate,
                                           const StaticSolveOptions& options, VecX* force) {
  const int n = system.num_nodes();
  const VecX v = VecX::Zero(3 * n);
  std::vector<int> free_index(3 * n, -1);
  int nf = 0;
  for (int k = 0; k < 3 * n; ++k)
    if (!fixed_coordinate[k]) free_index[k] = nf++;

  Evaluation eval;
  system.prepare(eval);
  StaticSolveResult result;
  Evaluated current = evaluate_loaded(system, x, v, options.load_factor, true, eval);
  result.residual_N = free_max_abs(current.force, fixed_coordinate);

  const BlockPattern& pattern = system.pattern();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SparseMatrix<double> H(nf, nf);
  VecX rhs(nf), step(3 * n), trial(3 * n);
  bool analysed = false;

  for (int it = 0; it < options.max_iterations; ++it) {
    if (result.residual_N <= options.force_tolerance_N) {
      result.converged = true;
      break;
    }
    result.iterations = it + 1;
    // Newton step on the free coordinates: (-K_ff) dx_f = f_f, with -K positive semi-definite
    // (the system projects its stiffness); a small diagonal shift keeps it definite.
    triplets.clear();
    double diagonal_scale = 0;
    for (int i = 0; i < n; ++i)
      for (int s = pattern.row_start()[i]; s < pattern.row_start()[i + 1]; ++s) {
        const int j = pattern.column()[s];
        const Mat3& b = eval.stiffness.block[s];
        for (int a = 0; a < 3; ++a)
          for (int c = 0; c < 3; ++c) {
            const int r = free_index[3 * i + a], q = free_index[3 * j + c];
            if (r < 0 || q < 0) continue;
            triplets.emplace_back(r, q, -b(a, c));
            if (r == q) diagonal_scale = std::max(diagonal_scale, -b(a, c));
          }
      }
    for (int r = 0; r < nf; ++r) triplets.emplace_back(r, r, 1e-12 * diagonal_scale);
    H.setFromTriplets(triplets.begin(), triplets.end());
    if (!analysed) {
      solver.analyzePattern(H);
      analysed = true;
    }
    solver.factorize(H);
    if (solver.info() != Eigen::Success) break;
    for (int k = 0; k < 3 * n; ++k)
      if (free_index[k] >= 0) rhs[free_index[k]] = current.force[k];
    const VecX dxf = solver.solve(rhs);
    step.setZero();
    for (int k = 0; k < 3 * n; ++k)
      if (free_index[k] >= 0) step[k] = dxf[free_index[k]];

    // Backtracking: accept a step that lowers the energy (Armijo) or the out-of-balance force.
    const double slope = -current.force.dot(step);  // directional derivative of the energy
    double t = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls, t *= 0.5) {
      trial = x + t * step;
      Evaluated next = evaluate_loaded(system, trial, v, options.load_factor, true, eval);
      const double residual = free_max_abs(next.force, fixed_coordinate);
      if (std::isfinite(next.energy) &&
          (next.energy <= current.energy + 1e-4 * t * slope || residual < result.residual_N)) {
        x = trial;
        current = std::move(next);
        result.residual_N = residual;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      evaluate_loaded(system, x, v, options.load_factor, true, eval);
      break;
    }
  }
  if (!result.converged && result.residual_N <= options.force_tolerance_N) result.converged = true;
  if (force) *force = current.force;
  return result;
}

}  // namespace weft
