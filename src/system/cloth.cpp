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

BendingModel parse_bending_model(const std::string& name, const std::string& where) {
  if (name == "plate") return BendingModel::kPlate;
  if (name == "hinge") return BendingModel::kHinge;
  throw InputError(where + ": unknown bending model '" + name + "' (expected plate or hinge)");
}

ClothModel build_cloth_model(TriMesh mesh, const Material& material, const Vec3& gravity,
                             const std::vector<int>& pins, BendingModel bending) {
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

  if (bending == BendingModel::kHinge) {
    for (const auto& s : interior_edge_stencils(mesh)) {
      BendingGeometry g;
      if (!make_bending_geometry(mesh.pattern[s[0]], mesh.pattern[s[1]], mesh.pattern[s[2]], mesh.pattern[s[3]],
                                 material.bending_rigidity_weft_Nm, material.bending_rigidity_warp_Nm, g))
        continue;  // a degenerate hinge carries no bending stiffness
      m.bending.push_back(hinge_stencil(s, g));
    }
  } else {
    m.bending = plate_bending_stencils(mesh, material.bending_rigidity_weft_Nm, material.bending_rigidity_warp_Nm);
  }
  for (const auto& b : m.bending)
    for (size_t a = 0; a < b.vertices.size(); ++a)
      for (size_t c = a + 1; c < b.vertices.size(); ++c) pairs.emplace_back(b.vertices[a], b.vertices[c]);
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
  for (const auto& b : m.bending) {
    const size_t k = b.vertices.size();
    std::vector<int> slots(k * k);
    for (size_t a = 0; a < k; ++a)
      for (size_t c = 0; c < k; ++c) slots[k * a + c] = m.pattern.slot(b.vertices[a], b.vertices[c]);
    m.bending_slots.push_back(std::move(slots));
    m.bending_mass_sums.push_back(b.stiffness_mass_sum(m.inverse_mass));
  }
  m.bending_slot_q.assign(m.pattern.num_blocks(), 0.0);
  for (size_t e = 0; e < m.bending.size(); ++e) {
    const auto& b = m.bending[e];
    const Eigen::Index k = b.Q.rows();
    for (Eigen::Index a = 0; a < k; ++a)
      for (Eigen::Index c = 0; c < k; ++c) m.bending_slot_q[m.bending_slots[e][k * a + c]] += b.Q(a, c);
  }
  return m;
}

ClothSystem::ClothSystem(const ClothModel& model, DampingSettings damping)
    : model_(model), damping_(damping) {
  membrane_viscosity_.assign(model.membranes.size(), Vec3::Constant(model.material.viscosity_Ns_m));
  // kappa_b = dt^2 S and lambda_b = dt gamma S, so lambda >= 2 zeta sqrt(kappa) means
  // gamma >= 2 zeta / sqrt(S): a constant per stencil (METHOD.md 4).
  const double zeta = damping_.damping_ratio;
  bending_damping_.resize(model.bending.size());
  bending_slot_damping_.assign(model.pattern.num_blocks(), 0.0);
  for (size_t e = 0; e < model.bending.size(); ++e) {
    const double S = model.bending_mass_sums[e];
    const double gamma = (zeta > 0 && S > 0) ? 2.0 * zeta / std::sqrt(S) : 0.0;
    bending_damping_[e] = gamma;
    const auto& Q = model.bending[e].Q;
    const Eigen::Index k = Q.rows();
    for (Eigen::Index a = 0; a < k; ++a)
      for (Eigen::Index c = 0; c < k; ++c) bending_slot_damping_[model.bending_slots[e][k * a + c]] += gamma * Q(a, c);
  }
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
  // The stencils' kappa depends on dt only: gathered once per dt, counted every step.
  if (dt != bending_kappa_dt_) {
    bending_kappa_step_ = LogStatistics();
    for (double S : model_.bending_mass_sums) bending_kappa_step_.add(dt * dt * S);
    bending_kappa_dt_ = dt;
  }
  stats_.bending_kappa.merge(bending_kappa_step_);
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

void ClothSystem::add_bending(const VecX& x, const VecX& v, const VecX* w, double ck, double cd, bool jacobians,
                              VecX& force, double& energy, double& viscous_power, BlockMatrix* first,
                              BlockMatrix* damping, VecX* stiffness_times_w) const {
  // Summed over the stencils, Q and gamma Q live on the block pattern (bending_slot_q and
  // bending_slot_damping_): E = 1/2 sum_ij Q_ij x_i . x_j; F = -Q x - gamma Q v;
  // K = -Q (x) I3; D = -gamma Q (x) I3.
  if (model_.bending.empty()) return;
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  const double* q = model_.bending_slot_q.data();
  const double* qd = bending_slot_damping_.data();
  for (int i = 0; i < num_nodes(); ++i) {
    Vec3 qx = Vec3::Zero(), qv = Vec3::Zero(), qw = Vec3::Zero();
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const int j = col[s];
      qx += q[s] * node(x, j);
      qv += qd[s] * node(v, j);
      if (w) qw += q[s] * node(*w, j);
      if (!jacobians) continue;
      if (damping) {
        first->block[s].diagonal().array() -= q[s];
        damping->block[s].diagonal().array() -= qd[s];
      } else {
        first->block[s].diagonal().array() += ck * q[s] + cd * qd[s];
      }
    }
    energy += 0.5 * node(x, i).dot(qx);
    viscous_power -= node(v, i).dot(qv);
    node(force, i) -= qx + qv;
    if (stiffness_times_w) node(*stiffness_times_w, i) -= qw;
  }
}

template <class AddJacobians>
void ClothSystem::add_gravity_and_membranes(
    const VecX& x, const VecX& v, bool jacobians, bool expand, VecX& force, double& elastic_energy,
    double& gravity_energy, double& viscous_power,
    const AddJacobians& add_jacobians) const {
  elastic_energy = gravity_energy = viscous_power = 0;
  for (int i = 0; i < num_nodes(); ++i) {
    node(force, i) += model_.mass[i] * model_.gravity;
    gravity_energy -= model_.mass[i] * model_.gravity.dot(node(x, i));
  }
  MembraneResult mr;
  std::array<Vec3, 3> xe, ve;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const auto& tri = model_.mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      xe[k] = node(x, tri[k]);
      ve[k] = node(v, tri[k]);
    }
    evaluate_membrane(model_.membranes[t], model_.material, membrane_viscosity_[t], xe, ve, jacobians, true, mr, expand);
    elastic_energy += mr.energy;
    viscous_power += mr.viscous_power;
    for (int k = 0; k < 3; ++k) node(force, tri[k]) += mr.force.segment<3>(3 * k);
    if (jacobians) add_jacobians(t, mr);
  }
}

void ClothSystem::assemble_step(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) {
  const int n = num_nodes();
  const bool jacobians = out.ck != 0.0 || out.cd != 0.0;
  out.force.resize(3 * n);
  out.force.setZero();
  out.stiffness_times_w = VecX::Zero(3 * n);
  if (out.matrix.pattern != &model_.pattern) out.matrix.reset(model_.pattern);
  out.matrix.set_zero();
  std::array<Vec3, 3> we, kw;
  add_gravity_and_membranes(x, v, jacobians, false, out.force, out.elastic_energy, out.gravity_energy,
                            out.viscous_power, [&](size_t t, const MembraneResult& mr) {
    const auto& tri = model_.mesh.triangles[t];
    const auto& slots = model_.membrane_slots[t];
    for (int p = 0; p < 6; ++p) {
      const int i = kMembranePairs[p][0], j = kMembranePairs[p][1];
      const Mat3 b = mr.jacobian.block(p, out.ck, out.cd);
      out.matrix.block[slots[3 * i + j]] += b;
      if (i != j) out.matrix.block[slots[3 * j + i]] += b.transpose();
    }
    for (int k = 0; k < 3; ++k) we[k] = node(w, tri[k]);
    mr.jacobian.stiffness_times(model_.membranes[t], we, kw);
    for (int k = 0; k < 3; ++k) node(out.stiffness_times_w, tri[k]) += kw[k];
  });
  add_bending(x, v, &w, out.ck, out.cd, jacobians, out.force, out.elastic_energy, out.viscous_power,
              jacobians ? &out.matrix : nullptr, nullptr, &out.stiffness_times_w);
}

double ClothSystem::viscous_power(const VecX& x, const VecX& v) {
  double power = 0;
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const auto& g = model_.membranes[t];
    const auto& tri = model_.mesh.triangles[t];
    Vec3 U = Vec3::Zero(), V = Vec3::Zero(), Ud = Vec3::Zero(), Vd = Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      U += g.ru[k] * node(x, tri[k]);
      V += g.rv[k] * node(x, tri[k]);
      Ud += g.ru[k] * node(v, tri[k]);
      Vd += g.rv[k] * node(v, tri[k]);
    }
    const Vec3 rate(U.dot(Ud), V.dot(Vd), U.dot(Vd) + V.dot(Ud));
    power -= g.area * membrane_viscosity_[t].dot(rate.cwiseAbs2());
  }
  if (model_.bending.empty()) return power;
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  for (int i = 0; i < num_nodes(); ++i) {
    Vec3 qv = Vec3::Zero();
    for (int s = rs[i]; s < rs[i + 1]; ++s) qv += bending_slot_damping_[s] * node(v, col[s]);
    power -= node(v, i).dot(qv);
  }
  return power;
}

void ClothSystem::evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) {
  const int n = num_nodes();
  if (out.force.size() != 3 * n || out.stiffness.pattern != &model_.pattern) prepare(out);
  out.force.setZero();
  if (jacobians) {
    out.stiffness.set_zero();
    out.damping.set_zero();
  }
  add_gravity_and_membranes(x, v, jacobians, true, out.force, out.elastic_energy, out.gravity_energy,
                            out.viscous_power, [&](size_t t, const MembraneResult& mr) {
    const auto& slots = model_.membrane_slots[t];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        out.stiffness.block[slots[3 * a + b]] += mr.stiffness.block<3, 3>(3 * a, 3 * b);
        out.damping.block[slots[3 * a + b]] += mr.damping.block<3, 3>(3 * a, 3 * b);
      }
  });
  add_bending(x, v, nullptr, 0.0, 0.0, jacobians, out.force, out.elastic_energy, out.viscous_power,
              jacobians ? &out.stiffness : nullptr, jacobians ? &out.damping : nullptr, nullptr);
}

}  // namespace weft
