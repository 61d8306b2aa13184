#include "system/cloth.hpp"

#include <cmath>
#include <string>

#include "weft/error.hpp"

namespace weft {

VecX ClothModel::initial_positions() const {
  VecX x(3 * num_vertices());
  for (int i = 0; i < num_vertices(); ++i) node(x, i) = mesh.positions.row(i).transpose();
  return x;
}

ClothModel build_cloth_model(TriMesh mesh, const Material& material, const Vec3& gravity,
                             const std::vector<int>& pins) {
  ClothModel m;
  m.material = material;
  m.gravity = gravity;
  const int n = mesh.num_vertices();
  if (!(material.surface_density_kg_m2 > 0))
    throw InputError("material surface density must be positive, got " +
                     std::to_string(material.surface_density_kg_m2));
  m.mass = VecX::Zero(n);
  m.membranes.resize(mesh.triangles.size());
  std::vector<std::pair<int, int>> pairs;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tri[k] < 0 || tri[k] >= n)
        throw InputError("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(tri[k]) +
                         ", the mesh has " + std::to_string(n));
    if (!make_membrane_geometry(mesh.pattern[tri[0]], mesh.pattern[tri[1]], mesh.pattern[tri[2]], m.membranes[t]))
      throw InputError("triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " +
                       std::to_string(tri[1]) + ", " + std::to_string(tri[2]) +
                       ") is degenerate in the pattern (zero area)");
    for (int k = 0; k < 3; ++k) m.mass[tri[k]] += material.surface_density_kg_m2 * m.membranes[t].area / 3.0;
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) pairs.emplace_back(tri[a], tri[b]);
  }
  for (int i = 0; i < n; ++i)
    if (!(m.mass[i] > 0)) throw InputError("vertex " + std::to_string(i) + " belongs to no triangle");
  m.fixed.assign(n, 0);
  for (int p : pins) {
    if (p < 0 || p >= n)
      throw InputError("pin refers to vertex " + std::to_string(p) + ", the mesh has " + std::to_string(n) + " vertices");
    m.fixed[p] = 1;
  }
  m.inverse_mass = m.mass.cwiseInverse();
  for (int i = 0; i < n; ++i)
    if (m.fixed[i]) m.inverse_mass[i] = 0.0;

  for (const auto& s : interior_edge_stencils(mesh)) {
    BendingGeometry g;
    if (!make_bending_geometry(mesh.pattern[s[0]], mesh.pattern[s[1]], mesh.pattern[s[2]], mesh.pattern[s[3]],
                               material.bending_rigidity_weft_Nm, material.bending_rigidity_warp_Nm, g))
      continue;  // a degenerate hinge carries no bending stiffness
    m.stencils.push_back(s);
    m.bendings.push_back(g);
    pairs.emplace_back(s[0], s[1]);
  }
  m.mesh = std::move(mesh);
  m.pattern = BlockPattern(n, pairs);
  for (size_t t = 0; t < m.membranes.size(); ++t) {
    const auto& tri = m.mesh.triangles[t];
    std::array<int, 9> slots;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) slots[3 * a + b] = m.pattern.slot(tri[a], tri[b]);
    m.membrane_slots.push_back(slots);
    const Vec3 inv(m.inverse_mass[tri[0]], m.inverse_mass[tri[1]], m.inverse_mass[tri[2]]);
    m.membrane_mass_sums.push_back(membrane_mass_sums(m.membranes[t].ru, m.membranes[t].rv, inv));
  }
  for (size_t e = 0; e < m.stencils.size(); ++e) {
    const auto& s = m.stencils[e];
    std::array<int, 16> slots;
    double sum = 0;
    for (int a = 0; a < 4; ++a) {
      sum += m.bendings[e].alpha[a] * m.bendings[e].alpha[a] * m.inverse_mass[s[a]];
      for (int b = 0; b < 4; ++b) slots[4 * a + b] = m.pattern.slot(s[a], s[b]);
    }
    m.bending_slots.push_back(slots);
    m.bending_alpha_mass_sums.push_back(sum);
  }
  return m;
}

ClothSystem::ClothSystem(const ClothModel& model, DampingSettings damping)
    : model_(model), damping_(damping) {
  membrane_viscosity_.assign(model.membranes.size(), Vec3::Constant(model.material.viscosity_Ns_m));
  bending_viscosity_.assign(model.bendings.size(), 0.0);
}

namespace {
Vec3 membrane_strain(const MembraneGeometry& g, const VecX& x, const std::array<int, 3>& tri) {
  Vec3 U = Vec3::Zero(), V = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    U += g.ru[k] * node(x, tri[k]);
    V += g.rv[k] * node(x, tri[k]);
  }
  return Vec3(0.5 * (U.dot(U) - 1), 0.5 * (V.dot(V) - 1), U.dot(V));
}
}  // namespace

std::vector<double> ClothSystem::membrane_kappa_max(const VecX& x, double dt) const {
  std::vector<double> out(model_.membranes.size());
  for (size_t t = 0; t < out.size(); ++t) {
    const auto& g = model_.membranes[t];
    const Vec3 E = membrane_tangent_moduli(model_.material, membrane_strain(g, x, model_.mesh.triangles[t]));
    out[t] = membrane_kappa(g.area, E, model_.membrane_mass_sums[t], dt).maxCoeff();
  }
  return out;
}

void ClothSystem::begin_step(const VecX& x, const VecX&, double step_dt) {
  // METHOD.md 4: per element and step, kappa and lambda from the tangent stiffness at the
  // current strain; raise the viscosity of each mode to reach the target damping ratio.
  const double dt = damping_.reference_dt > 0 ? damping_.reference_dt : step_dt;
  const double zeta = damping_.damping_ratio;
  const double eta0 = model_.material.viscosity_Ns_m;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const auto& g = model_.membranes[t];
    const Vec3& S = model_.membrane_mass_sums[t];
    const Vec3 E = membrane_tangent_moduli(model_.material, membrane_strain(g, x, model_.mesh.triangles[t]));
    Vec3 eta = Vec3::Constant(eta0);
    if (zeta > 0) eta = eta.cwiseMax(membrane_required_viscosity(g.area, E, S, zeta));
    membrane_viscosity_[t] = eta;
    const Vec3 kappa = membrane_kappa(g.area, E, S, dt);
    int mode;
    stats_.membrane_kappa.add(kappa.maxCoeff(&mode));
    stats_.membrane_lambda.add(membrane_lambda(g.area, eta, S, dt)[mode]);
    const double added = (eta - Vec3::Constant(eta0)).maxCoeff();
    ++stats_.element_steps;
    if (added > 0) {
      ++stats_.raised_element_steps;
      stats_.added_viscosity.add(added);
    }
  }
  for (size_t e = 0; e < model_.bendings.size(); ++e) {
    const auto& g = model_.bendings[e];
    const double sum = model_.bending_alpha_mass_sums[e];
    bending_viscosity_[e] = zeta > 0 ? bending_required_viscosity(g.stiffness, sum, zeta) : 0.0;
    stats_.bending_kappa.add(bending_kappa(g.stiffness, sum, dt));
  }
}

VecX ClothSystem::added_viscosity_per_vertex() const {
  const int n = model_.num_vertices();
  VecX sum = VecX::Zero(n), weight = VecX::Zero(n);
  const double eta0 = model_.material.viscosity_Ns_m;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const double added = (membrane_viscosity_[t] - Vec3::Constant(eta0)).maxCoeff();
    for (int k : model_.mesh.triangles[t]) {
      sum[k] += model_.membranes[t].area * added;
      weight[k] += model_.membranes[t].area;
    }
  }
  return sum.cwiseQuotient(weight);
}

void ClothSystem::evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) {
  const int n = num_nodes();
  if (out.force.size() != 3 * n || out.stiffness.pattern != &model_.pattern) prepare(out);
  out.force.setZero();
  if (jacobians) {
    out.stiffness.set_zero();
    out.damping.set_zero();
  }
  out.elastic_energy = 0;
  out.gravity_energy = 0;
  out.viscous_power = 0;
  for (int i = 0; i < n; ++i) {
    node(out.force, i) += model_.mass[i] * model_.gravity;
    out.gravity_energy -= model_.mass[i] * model_.gravity.dot(node(x, i));
  }
  MembraneResult mr;
  std::array<Vec3, 3> xe, ve;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const auto& tri = model_.mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      xe[k] = node(x, tri[k]);
      ve[k] = node(v, tri[k]);
    }
    evaluate_membrane(model_.membranes[t], model_.material, membrane_viscosity_[t], xe, ve, jacobians, true, mr);
    out.elastic_energy += mr.energy;
    out.viscous_power += mr.viscous_power;
    for (int k = 0; k < 3; ++k) node(out.force, tri[k]) += mr.force.segment<3>(3 * k);
    if (jacobians) {
      const auto& slots = model_.membrane_slots[t];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          out.stiffness.block[slots[3 * a + b]] += mr.stiffness.block<3, 3>(3 * a, 3 * b);
          out.damping.block[slots[3 * a + b]] += mr.damping.block<3, 3>(3 * a, 3 * b);
        }
    }
  }
  BendingResult br;
  std::array<Vec3, 4> xb, vb;
  for (size_t e = 0; e < model_.bendings.size(); ++e) {
    const auto& s = model_.stencils[e];
    const auto& g = model_.bendings[e];
    for (int k = 0; k < 4; ++k) {
      xb[k] = node(x, s[k]);
      vb[k] = node(v, s[k]);
    }
    evaluate_bending(g, bending_viscosity_[e], xb, vb, br);
    out.elastic_energy += br.energy;
    out.viscous_power += br.viscous_power;
    for (int k = 0; k < 4; ++k) node(out.force, s[k]) += br.force.segment<3>(3 * k);
    if (jacobians) {
      const auto& slots = model_.bending_slots[e];
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
          const double w = g.alpha[a] * g.alpha[b];
          out.stiffness.block[slots[4 * a + b]].diagonal().array() -= g.stiffness * w;
          out.damping.block[slots[4 * a + b]].diagonal().array() -= bending_viscosity_[e] * w;
        }
    }
  }
}

}  // namespace weft
