// Adaptive damping in the cloth system: the membranes' stiffness factors, the viscosity each
// triangle is given at a step's start (ClothSystem::begin_step) and its per-vertex report.
#include "system/cloth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace weft {

namespace {
Vec3 membrane_strain(const MembraneGeometry& g, const VecX& x, const std::array<int, 3>& tri) {
  double U[3], V[3];
  membrane::gradient(g.ru.data(), g.rv.data(), [&](int k, int c) { return x[3 * tri[k] + c]; }, U, V);
  const membrane::Modes<double> e = membrane::green_strain(U, V);
  return Vec3(e.uu, e.vv, e.uv);
}
}  // namespace

std::vector<double> ClothSystem::membrane_kappa_max(const VecX& x, double dt) const {
  std::vector<double> out(model_.membranes.size());
  for (size_t t = 0; t < out.size(); ++t) {
    const auto& g = model_.membranes[t];
    const Vec3 E = membrane_tangent_moduli(model_.material_of(t), membrane_strain(g, x, model_.mesh.triangles[t]));
    out[t] = membrane_kappa(g.area, E, model_.membrane_mass_sums[t], dt).maxCoeff();
  }
  return out;
}

void ClothSystem::prepare_linear_damping(double dt) {
  if (d_.linear_viscosity_ready && dt == d_.linear_stats_dt) return;
  const double zeta = c_.damping.damping_ratio;
  // Linear curves: each material's moduli are its tangents at every strain.
  std::vector<Vec3> moduli;
  for (const Material& m : model_.materials) moduli.push_back(membrane_tangent_moduli(m, Vec3::Zero()));
  if (!d_.linear_viscosity_ready) {
    for (size_t t = 0; t < model_.membranes.size(); ++t) {
      const Vec3& E = moduli[model_.material_index(t)];
      Vec3 eta = Vec3::Constant(model_.material_of(t).viscosity_Ns_m);
      if (zeta > 0)
        eta = eta.cwiseMax(membrane_required_viscosity(model_.membranes[t].area, E, model_.membrane_mass_sums[t], zeta));
      d_.membrane_viscosity[t] = eta;
    }
    d_.linear_viscosity_ready = true;
  }
  if (dt == d_.linear_stats_dt) return;
  d_.linear_kappa_step = LogStatistics();
  d_.linear_lambda_step = LogStatistics();
  d_.linear_added_step = LogStatistics();
  d_.linear_raised_per_step = 0;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const double area = model_.membranes[t].area;
    const Vec3& S = model_.membrane_mass_sums[t];
    const Vec3& eta = d_.membrane_viscosity[t];
    const double eta0 = model_.material_of(t).viscosity_Ns_m;
    const Vec3 kappa = membrane_kappa(area, moduli[model_.material_index(t)], S, dt);
    int mode;
    d_.linear_kappa_step.add(kappa.maxCoeff(&mode));
    d_.linear_lambda_step.add(membrane_lambda(area, eta, S, dt)[mode]);
    const double added = (eta - Vec3::Constant(eta0)).maxCoeff();
    if (added > 0) {
      ++d_.linear_raised_per_step;
      d_.linear_added_step.add(added);
    }
  }
  d_.linear_stats_dt = dt;
}

void ClothSystem::begin_step(const VecX& x, const VecX&, double step_dt) {
  // docs/method.md 4: per element and step, kappa and lambda from the tangent stiffness at the
  // current strain; raise the viscosity of each mode to reach the target damping ratio.
  const double dt = c_.damping.reference_dt > 0 ? c_.damping.reference_dt : step_dt;
  const double zeta = c_.damping.damping_ratio;
  if (c_.linear_moduli) {
    // Linear curves: the moduli, hence the viscosity and the factors, do not depend on the
    // strain; the step's statistics are the same every step of the same dt.
    prepare_linear_damping(dt);
    d_.statistics.membrane_kappa.merge(d_.linear_kappa_step);
    d_.statistics.membrane_lambda.merge(d_.linear_lambda_step);
    d_.statistics.added_viscosity.merge(d_.linear_added_step);
    d_.statistics.element_steps += static_cast<long>(model_.membranes.size());
    d_.statistics.raised_element_steps += d_.linear_raised_per_step;
  } else {
    for (size_t t = 0; t < model_.membranes.size(); ++t) {
      const auto& g = model_.membranes[t];
      const Vec3& S = model_.membrane_mass_sums[t];
      const Material& material = model_.material_of(t);
      const double eta0 = material.viscosity_Ns_m;
      const Vec3 E = membrane_tangent_moduli(material, membrane_strain(g, x, model_.mesh.triangles[t]));
      Vec3 eta = Vec3::Constant(eta0);
      if (zeta > 0) eta = eta.cwiseMax(membrane_required_viscosity(g.area, E, S, zeta));
      d_.membrane_viscosity[t] = eta;
      const Vec3 kappa = membrane_kappa(g.area, E, S, dt);
      int mode;
      d_.statistics.membrane_kappa.add(kappa.maxCoeff(&mode));
      d_.statistics.membrane_lambda.add(membrane_lambda(g.area, eta, S, dt)[mode]);
      const double added = (eta - Vec3::Constant(eta0)).maxCoeff();
      ++d_.statistics.element_steps;
      if (added > 0) {
        ++d_.statistics.raised_element_steps;
        d_.statistics.added_viscosity.add(added);
      }
    }
  }
  // The stencils' kappa depends on dt only: gathered once per dt, counted every step.
  if (dt != d_.bending_kappa_dt) {
    d_.bending_kappa_step = LogStatistics();
    for (double S : model_.bending_mass_sums) d_.bending_kappa_step.add(dt * dt * S);
    d_.bending_kappa_dt = dt;
  }
  d_.statistics.bending_kappa.merge(d_.bending_kappa_step);
}

VecX ClothSystem::added_viscosity_per_vertex() const {
  const int n = model_.num_vertices();
  VecX sum = VecX::Zero(n), weight = VecX::Zero(n);
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const double added = (d_.membrane_viscosity[t] - Vec3::Constant(model_.material_of(t).viscosity_Ns_m)).maxCoeff();
    for (int k : model_.mesh.triangles[t]) {
      sum[k] += model_.membranes[t].area * added;
      weight[k] += model_.membranes[t].area;
    }
  }
  return sum.cwiseQuotient(weight);
}

}  // namespace weft
