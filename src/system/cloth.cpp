#include "system/cloth.hpp"

#include "linalg/dispatch.hpp"
#include "util/threads.hpp"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "weft/error.hpp"

namespace weft {

// Sets the membrane pass's pieces and groups (Constants::membrane_pieces, membrane_groups) and
// returns the order the pass takes the triangles in.
std::vector<int> ClothSystem::group_membrane_pieces(const ClothModel& model, Constants& c) {
  // The membrane pass's pieces, grouped by a greedy colouring of the pieces that share a
  // vertex (a grid's rows of triangles take two groups), and the order the pass takes the
  // triangles in: group by group, piece by piece, then the last count % 4 triangles.
  const int count = static_cast<int>(model.membranes.size());
  const int batched = count - count % 4;
  std::vector<std::pair<int, int>> pieces;
  for (int b = 0; b < batched; b += kMembranePiece) pieces.emplace_back(b, std::min(batched, b + kMembranePiece));
  std::vector<std::vector<int>> vertex_pieces(model.num_vertices());
  for (size_t k = 0; k < pieces.size(); ++k)
    for (int t = pieces[k].first; t < pieces[k].second; ++t)
      for (int i : model.mesh.triangles[t])
        if (vertex_pieces[i].empty() || vertex_pieces[i].back() != static_cast<int>(k))
          vertex_pieces[i].push_back(static_cast<int>(k));
  std::vector<int> group(pieces.size(), -1);
  int groups = 0;
  for (size_t k = 0; k < pieces.size(); ++k) {
    std::vector<char> taken(groups + 1, 0);
    for (int t = pieces[k].first; t < pieces[k].second; ++t)
      for (int i : model.mesh.triangles[t])
        for (int other : vertex_pieces[i])
          if (group[other] >= 0) taken[group[other]] = 1;
    group[k] = static_cast<int>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    groups = std::max(groups, group[k] + 1);
  }
  for (int g = 0; g < groups; ++g) {
    c.membrane_groups.push_back(static_cast<int>(c.membrane_pieces.size()));
    for (size_t k = 0; k < pieces.size(); ++k)
      if (group[k] == g) c.membrane_pieces.push_back(pieces[k]);
  }
  c.membrane_groups.push_back(static_cast<int>(c.membrane_pieces.size()));
  std::vector<int> pass_order;
  pass_order.reserve(count);
  for (const auto& [begin, end] : c.membrane_pieces)
    for (int t = begin; t < end; ++t) pass_order.push_back(t);
  for (int t = batched; t < count; ++t) pass_order.push_back(t);
  return pass_order;
}

ClothSystem::Constants ClothSystem::make_constants(const ClothModel& model, DampingSettings damping) {
  Constants c;
  c.damping = damping;
  // kappa_b = dt^2 S and lambda_b = dt gamma S, so lambda >= 2 zeta sqrt(kappa) means
  // gamma >= 2 zeta / sqrt(S): a constant per stencil (docs/method.md 4).
  const double zeta = c.damping.damping_ratio;
  c.bending_damping.resize(model.bending.size());
  c.bending_slot_damping.assign(model.pattern.num_blocks(), 0.0);
  for (size_t e = 0; e < model.bending.size(); ++e) {
    const double S = model.bending_mass_sums[e];
    const double gamma = (zeta > 0 && S > 0) ? 2.0 * zeta / std::sqrt(S) : 0.0;
    c.bending_damping[e] = gamma;
    const auto& Q = model.bending[e].Q;
    const Eigen::Index k = Q.rows();
    for (Eigen::Index a = 0; a < k; ++a)
      for (Eigen::Index b = 0; b < k; ++b) c.bending_slot_damping[model.bending_slots[e][k * a + b]] += gamma * Q(a, b);
  }
  c.linear_moduli = true;
  for (const Material& mat : model.materials) {
    MaterialConstants mc;
    mc.material = &mat;
    mc.linear = membrane::LinearCurves<double>::of(mat);
    mc.viscosity = mat.viscosity_Ns_m;
    c.material_constants.push_back(mc);
    c.linear_moduli = c.linear_moduli && mat.weft.is_linear() && mat.warp.is_linear() && mat.shear.is_linear();
  }
  c.mixed = model.materials.size() > 1;
  const std::vector<int> pass_order = group_membrane_pieces(model, c);

  // Packed triangles; the first triangle (in the pass's order) to touch a block slot assigns it.
  std::vector<char> written(model.pattern.num_blocks(), 0);
  c.triangles.resize(model.membranes.size());
  for (int t : pass_order) {
    PackedTriangle& p = c.triangles[t];
    const auto& g = model.membranes[t];
    p.vertex = model.mesh.triangles[t];
    p.material = static_cast<int>(model.material_index(t));
    p.slot = model.membrane_slots[t];
    for (int k = 0; k < 3; ++k) {
      p.ru[k] = g.ru[k];
      p.rv[k] = g.rv[k];
    }
    p.area = g.area;
    p.first_writer = 0;
    for (int k = 0; k < 9; ++k)
      if (!written[p.slot[k]]) {
        written[p.slot[k]] = 1;
        p.first_writer |= 1u << k;
      }
  }
  // A row's slots that no membrane writes go with the first triangle that touches the row.
  const auto& rs = model.pattern.row_start();
  std::vector<char> row_done(model.num_vertices(), 0);
  for (int t : pass_order) {
    PackedTriangle& p = c.triangles[t];
    p.bending_only_begin = static_cast<int>(c.bending_only_slots.size());
    for (int i : p.vertex) {
      if (row_done[i]) continue;
      row_done[i] = 1;
      for (int s = rs[i]; s < rs[i + 1]; ++s)
        if (!written[s]) c.bending_only_slots.push_back(s);
    }
    p.bending_only_end = static_cast<int>(c.bending_only_slots.size());
  }
  c.constant_slots.assign(model.pattern.num_blocks(), 0);
  for (int slot : c.bending_only_slots) c.constant_slots[slot] = 1;
  return c;
}

ClothSystem::Data ClothSystem::make_data(const ClothModel& model) {
  Data d;
  d.membrane_viscosity.resize(model.membranes.size());
  for (size_t t = 0; t < d.membrane_viscosity.size(); ++t)
    d.membrane_viscosity[t] = Vec3::Constant(model.material_of(t).viscosity_Ns_m);
  return d;
}

ClothSystem::ClothSystem(const ClothModel& model, DampingSettings damping)
    : own_constants_(std::make_unique<Constants>(make_constants(model, damping))),
      own_data_(std::make_unique<Data>(make_data(model))),
      model_(model),
      c_(*own_constants_),
      d_(*own_data_) {}

ClothSystem::ClothSystem(const ClothModel& model, const Constants& constants, Data& data)
    : model_(model), c_(constants), d_(data) {}

void ClothSystem::add_bending(const VecX& x, const VecX& v, bool jacobians, VecX& force, double& energy,
                              double& viscous_power, BlockMatrix* stiffness, BlockMatrix* damping) const {
  // Summed over the stencils, Q and gamma Q live on the block pattern (bending_slot_q and
  // c_.bending_slot_damping): E = 1/2 sum_ij Q_ij x_i . x_j; F = -Q x - gamma Q v;
  // K = -Q (x) I3; D = -gamma Q (x) I3.
  if (model_.bending.empty()) return;
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  const double* q = model_.bending_slot_q.data();
  const double* qd = c_.bending_slot_damping.data();
  for (int i = 0; i < num_nodes(); ++i) {
    Vec3 qx = Vec3::Zero(), qv = Vec3::Zero();
    for (int s = rs[i]; s < rs[i + 1]; ++s) {
      const int j = col[s];
      qx += q[s] * node(x, j);
      qv += qd[s] * node(v, j);
      if (!jacobians) continue;
      stiffness->block[s].diagonal().array() -= q[s];
      damping->block[s].diagonal().array() -= qd[s];
    }
    energy += 0.5 * node(x, i).dot(qx);
    viscous_power -= node(v, i).dot(qv);
    node(force, i) -= qx + qv;
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
    evaluate_membrane(model_.membranes[t], model_.material_of(t), d_.membrane_viscosity[t], xe, ve, jacobians, true, mr,
                      expand);
    elastic_energy += mr.energy;
    viscous_power += mr.viscous_power;
    for (int k = 0; k < 3; ++k) node(force, tri[k]) += mr.force.segment<3>(3 * k);
    if (jacobians) add_jacobians(t, mr);
  }
}

namespace {
// A triangle's four matrices Muu, Muv, Mvu, Mvv (below), each as column-major entries 0-3
// (lo), 4-7 (hi) and 8; Muv and Mvu share entry 8.
struct TriangleMatrices {
  Eigen::Array4d uu_lo, uu_hi, uv_lo, uv_hi, vu_lo, vu_hi, vv_lo, vv_hi;
  double uu_8, x_8, vv_8;
};

// Writes a triangle's nine step-matrix blocks: (i, j) = r_u,i r_u,j Muu + r_u,i r_v,j Muv +
// r_v,i r_u,j Mvu + r_v,i r_v,j Mvv. The first triangle to reach a slot assigns it (and adds
// the slot's bending diagonal), the others add to it; the bending-only slots listed for
// this triangle get their diagonal.
template <class Triangle>
inline void write_triangle_blocks(const Triangle& tr, const double* ru, const double* rv, const TriangleMatrices& M,
                                  Mat3* blocks, const int* bending_only_slots, const double* q, const double* qd,
                                  double ck, double cd) {
  using A4 = Eigen::Array4d;
  const A4 first_entry(1.0, 0.0, 0.0, 0.0);
  for (int k = tr.bending_only_begin; k < tr.bending_only_end; ++k) {
    const int slot = bending_only_slots[k];
    const double diagonal = ck * q[slot] + cd * qd[slot];
    double* out_block = blocks[slot].data();
    Eigen::Map<A4> out_lo(out_block), out_hi(out_block + 4);
    out_lo = diagonal * first_entry;
    out_hi = diagonal * first_entry;
    out_block[8] = diagonal;
  }
  const unsigned first = tr.first_writer;
  // Four doubles as one vector of the instruction set the caller is compiled for (Eigen's
  // arrays take their width from the build's flags, not from a kernel's clone).
  typedef double V4 __attribute__((vector_size(32), aligned(8), may_alias));
  const auto load = [](const double* p) { return *reinterpret_cast<const V4*>(p); };
  const V4 uu_lo = load(M.uu_lo.data()), uu_hi = load(M.uu_hi.data()), uv_lo = load(M.uv_lo.data()),
           uv_hi = load(M.uv_hi.data()), vu_lo = load(M.vu_lo.data()), vu_hi = load(M.vu_hi.data()),
           vv_lo = load(M.vv_lo.data()), vv_hi = load(M.vv_hi.data());
  const V4 first_lane = {1.0, 0.0, 0.0, 0.0};
  const auto put = [&](int bit, double cuu, double cuv, double cvu, double cvv) __attribute__((always_inline)) {
    const int slot = tr.slot[bit];
    double* out_block = blocks[slot].data();
    const V4 lo = cuu * uu_lo + cuv * uv_lo + cvu * vu_lo + cvv * vv_lo;
    const V4 hi = cuu * uu_hi + cuv * uv_hi + cvu * vu_hi + cvv * vv_hi;
    const double last = cuu * M.uu_8 + (cuv + cvu) * M.x_8 + cvv * M.vv_8;
    V4& out_lo = *reinterpret_cast<V4*>(out_block);
    V4& out_hi = *reinterpret_cast<V4*>(out_block + 4);
    if (first & (1u << bit)) {
      const double bending = ck * q[slot] + cd * qd[slot];
      out_lo = lo + bending * first_lane;
      out_hi = hi + bending * first_lane;
      out_block[8] = last + bending;
    } else {
      out_lo += lo;
      out_hi += hi;
      out_block[8] += last;
    }
  };
#pragma GCC unroll 6
  for (int p = 0; p < 6; ++p) {
    const int i = kMembranePairs[p][0], j = kMembranePairs[p][1];
    const double cuu = ru[i] * ru[j], cuv = ru[i] * rv[j], cvu = rv[i] * ru[j], cvv = rv[i] * rv[j];
    put(3 * i + j, cuu, cuv, cvu, cvv);
    if (i != j) put(3 * j + i, cuu, cvu, cuv, cvv);  // the transpose: r_u,j r_v,i goes with Muv
  }
}
}  // namespace

ClothSystem::MembraneArrays ClothSystem::membrane_arrays(const VecX& x, const VecX& v, const VecX& w,
                                                       StepAssembly& out) const {
  return {x.data(), v.data(), w.data(), out.force.data(), out.stiffness_times_w.data(), out.matrix.block.data(),
          model_.bending_slot_q.data(), c_.bending_slot_damping.data(), d_.membrane_viscosity.data()};
}

// The four matrices of membrane::step_matrices as write_triangle_blocks takes them.
inline TriangleMatrices triangle_matrices(const double m[4][9]) {
  TriangleMatrices M;
  M.uu_lo = Eigen::Array4d(m[0][0], m[0][1], m[0][2], m[0][3]);
  M.uu_hi = Eigen::Array4d(m[0][4], m[0][5], m[0][6], m[0][7]);
  M.uv_lo = Eigen::Array4d(m[1][0], m[1][1], m[1][2], m[1][3]);
  M.uv_hi = Eigen::Array4d(m[1][4], m[1][5], m[1][6], m[1][7]);
  M.vu_lo = Eigen::Array4d(m[2][0], m[2][1], m[2][2], m[2][3]);
  M.vu_hi = Eigen::Array4d(m[2][4], m[2][5], m[2][6], m[2][7]);
  M.vv_lo = Eigen::Array4d(m[3][0], m[3][1], m[3][2], m[3][3]);
  M.vv_hi = Eigen::Array4d(m[3][4], m[3][5], m[3][6], m[3][7]);
  M.uu_8 = m[0][8];
  M.x_8 = m[1][8];  // Muv and Mvu share their last entry
  M.vv_8 = m[3][8];
  return M;
}

template <bool kLinear, bool kMixed>
WEFT_HOT_KERNEL void ClothSystem::assemble_membranes(const VecX& x, const VecX& v, const VecX& w, bool jacobians,
                                                     size_t begin, size_t end, StepAssembly& out) const {
  // The membrane kernel (elements/membrane_kernel.hpp) one triangle at a time, triangles
  // [begin, end): forces, energy, viscous power, K w and the step matrix blocks (from the
  // four matrices of membrane::step_matrices; write_triangle_blocks). One material: its
  // constants read once, before the loop; several: per triangle.
  using namespace membrane;
  const MaterialConstants* constants = c_.material_constants.data();
  const double ck = out.ck, cd = out.cd;
  const MembraneArrays arrays = membrane_arrays(x, v, w, out);
  const double *X = arrays.X, *Vel = arrays.Vel, *W = arrays.W, *q = arrays.q, *qd = arrays.qd;
  double *F = arrays.F, *KW = arrays.KW;
  Mat3* blocks = arrays.blocks;
  const Vec3* viscosity = arrays.viscosity;
  double* energy = d_.triangle_energy.data();
  double* power = d_.triangle_power.data();
  for (size_t t = begin; t < end; ++t) {
    const PackedTriangle& tr = c_.triangles[t];
    const MaterialConstants& mc = constants[kMixed ? tr.material : 0];
    const double A = tr.area;
    const double* ru = tr.ru;
    const double* rv = tr.rv;
    const int o[3] = {3 * tr.vertex[0], 3 * tr.vertex[1], 3 * tr.vertex[2]};
    double U[3], V[3], Ud[3], Vd[3];
    gradient(ru, rv, [&](int k, int c) { return X[o[k] + c]; }, U, V);
    gradient(ru, rv, [&](int k, int c) { return Vel[o[k] + c]; }, Ud, Vd);
    const Modes<double> eta{viscosity[t][0], viscosity[t][1], viscosity[t][2]};
    const auto assemble = [&](const auto& curves) __attribute__((always_inline)) {
      Forces<double> f;
      forces(curves, A, eta, U, V, Ud, Vd, f);
      energy[t] = f.energy;
      power[t] = f.viscous_power;
      scatter_force(f, ru, rv, U, V, [&](int i, int c, double value) { F[o[i] + c] -= value; });
      if (!jacobians) return;
      const Stiffness<double> k = definite_stiffness(curves, f);
      double dU[3], dV[3];
      gradient(ru, rv, [&](int i, int c) { return W[o[i] + c]; }, dU, dV);
      scatter_stiffness_times(k, A, ru, rv, U, V, dU, dV, [&](int i, int c, double value) { KW[o[i] + c] -= value; });
      double m[4][9];
      step_matrices(k, eta, A, ck, cd, U, V, m);
      write_triangle_blocks(tr, ru, rv, triangle_matrices(m), blocks, c_.bending_only_slots.data(), q, qd, ck, cd);
    };
    if constexpr (kLinear) assemble(mc.linear);
    else assemble(MaterialCurves(*mc.material));
  }
}

namespace {
// Four doubles, one per triangle of a batch (membrane_kernel.hpp's Double4).
using D4 = Double4;

inline D4 splat(double a) { return D4{a, a, a, a}; }
// Node j's three values of a vertex field y in lanes 0-2 of a D4. Lane 3 is the next
// node's first value (not to be used) when node j has a next one, else 0.
template <bool kHasNext>
inline D4 node_values(const double* y, int j) {
  if constexpr (!kHasNext) return D4{y[3 * j], y[3 * j + 1], y[3 * j + 2], 0.0};
  D4 v;
  std::memcpy(&v, y + 3 * j, sizeof v);
  return v;
}
// A batch of four triangles: lane l of each D4 is triangle tr[l]'s area and shape-function
// gradients r_u, r_v; o[k][l] the offset of its vertex k.
struct TriangleBatch {
  D4 A, ru[3], rv[3];
  int o[3][4];
  template <class Triangle>
  explicit TriangleBatch(const Triangle* const* tr) {
    A = D4{tr[0]->area, tr[1]->area, tr[2]->area, tr[3]->area};
    for (int k = 0; k < 3; ++k) {
      ru[k] = D4{tr[0]->ru[k], tr[1]->ru[k], tr[2]->ru[k], tr[3]->ru[k]};
      rv[k] = D4{tr[0]->rv[k], tr[1]->rv[k], tr[2]->rv[k], tr[3]->rv[k]};
      for (int l = 0; l < 4; ++l) o[k][l] = 3 * tr[l]->vertex[k];
    }
  }
  /// U = sum_k r_u,k y_k and V = sum_k r_v,k y_k of a vertex field y (positions give the
  /// deformation gradient, velocities its rate). Always inlined: an out-of-line copy would be
  /// compiled for the baseline instruction set, not for the kernel's clone.
  __attribute__((always_inline)) void gradient(const double* y, D4* U, D4* V) const {
    membrane::gradient(ru, rv, [&](int k, int c) __attribute__((always_inline)) { return gather(y, k, c); }, U, V);
  }
  /// Component c of the batch's k-th vertices in a vertex field y.
  __attribute__((always_inline)) D4 gather(const double* y, int k, int c) const {
    return D4{y[o[k][0] + c], y[o[k][1] + c], y[o[k][2] + c], y[o[k][3] + c]};
  }
  /// The viscosities of the four triangles per mode (weft, warp, shear).
  static membrane::Modes<D4> viscosity(const Vec3* eta, size_t t0) {
    const auto mode = [&](int m) { return D4{eta[t0][m], eta[t0 + 1][m], eta[t0 + 2][m], eta[t0 + 3][m]}; };
    return {mode(0), mode(1), mode(2)};
  }
};
}  // namespace

template <bool kMixed>
WEFT_HOT_KERNEL void ClothSystem::assemble_membranes_batched(const VecX& x, const VecX& v, const VecX& w,
                                                             size_t begin, size_t end, StepAssembly& out) const {
  // assemble_membranes<true> with the membrane kernel run on four triangles at a time, lane l
  // of every D4 belonging to triangle t + l: the same expressions, so the same values. The
  // results go through a small per-batch table (the four matrices then transposed to one
  // row of entries per triangle) to the scalar scatter (forces, K w) and the block writer,
  // which take the triangles in order (the first writer of each block slot is unchanged).
  // The batch's U and V are kept in out.element_data for step_viscous_power.
  // Linear curves: the tangent moduli are the moduli (clamped), the same for every triangle
  // of a material. One material: scalars, set once; several: four lanes, set per batch.
  using namespace membrane;
  using Moduli = std::conditional_t<kMixed, D4, double>;
  const MaterialConstants* constants = c_.material_constants.data();
  LinearCurves<Moduli> curves{};
  if constexpr (!kMixed) curves = constants[0].linear;
  const double ck = out.ck, cd = out.cd;
  const MembraneArrays arrays = membrane_arrays(x, v, w, out);
  const double *X = arrays.X, *Vel = arrays.Vel, *W = arrays.W, *q = arrays.q, *qd = arrays.qd;
  double *F = arrays.F, *KW = arrays.KW;
  Mat3* blocks = arrays.blocks;
  const Vec3* viscosity = arrays.viscosity;
  // Per batch: force and K w per vertex and component (9 + 9) and the four matrices' 9
  // entries each (Muu, Muv, Mvu, Mvv), lane by lane (a row per quantity, a lane per triangle).
  enum { kForce = 0, kStiffness = 9, kMatrices = 18, kRows = 54 };
  alignas(32) double table[kRows][4];
  const auto row = [&table](int k) __attribute__((always_inline)) -> D4& { return *reinterpret_cast<D4*>(table[k]); };
  for (size_t t0 = begin; t0 < end; t0 += 4) {
    const PackedTriangle* tr[4] = {&c_.triangles[t0], &c_.triangles[t0 + 1], &c_.triangles[t0 + 2], &c_.triangles[t0 + 3]};
    const TriangleBatch batch(tr);
    if constexpr (kMixed) {
      const LinearCurves<double>* c[4] = {&constants[tr[0]->material].linear, &constants[tr[1]->material].linear,
                                          &constants[tr[2]->material].linear, &constants[tr[3]->material].linear};
      const auto lanes = [&c](double LinearCurves<double>::*field) {
        return D4{c[0]->*field, c[1]->*field, c[2]->*field, c[3]->*field};
      };
      using L = LinearCurves<double>;
      curves = {lanes(&L::weft),       lanes(&L::warp),       lanes(&L::shear),      lanes(&L::coupling),
                lanes(&L::tangent_uu), lanes(&L::tangent_vv), lanes(&L::tangent_uv), lanes(&L::tangent_coupling)};
    }
    const D4& A = batch.A;
    const D4* ru = batch.ru;
    const D4* rv = batch.rv;
    const auto& o = batch.o;
    const Modes<D4> eta = TriangleBatch::viscosity(viscosity, t0);
    // Deformation gradient, its rate and its change along w.
    D4 U[3], V[3], Ud[3], Vd[3], dU[3], dV[3];
    batch.gradient(X, U, V);
    batch.gradient(Vel, Ud, Vd);
    batch.gradient(W, dU, dV);
    // Kept for step_viscous_power: U and V of the batch, six D4.
    D4* frame = reinterpret_cast<D4*>(out.element_data.data() + 6 * t0);
    for (int c = 0; c < 3; ++c) {
      frame[c] = U[c];
      frame[3 + c] = V[c];
    }
    Forces<D4> f;
    forces(curves, A, eta, U, V, Ud, Vd, f);
    std::memcpy(d_.triangle_energy.data() + t0, &f.energy, sizeof(D4));
    std::memcpy(d_.triangle_power.data() + t0, &f.viscous_power, sizeof(D4));
    const Stiffness<D4> k = definite_stiffness(curves, f);
    scatter_force(f, ru, rv, U, V, [&](int i, int c, D4 value) __attribute__((always_inline)) {
      row(kForce + 3 * i + c) = value;
    });
    scatter_stiffness_times(k, A, ru, rv, U, V, dU, dV, [&](int i, int c, D4 value) __attribute__((always_inline)) {
      row(kStiffness + 3 * i + c) = value;
    });
    D4 m[4][9];
    step_matrices(k, eta, A, ck, cd, U, V, m);
    for (int mm = 0; mm < 4; ++mm)
      for (int e = 0; e < 9; ++e) row(kMatrices + 9 * mm + e) = m[mm][e];
    // The four matrices' first eight entries by triangle (4x4 transposes of the table's rows):
    // lane l's Muu, Muv, Mvu, Mvv entries 0-3 and 4-7 in TriangleMatrices' order.
    alignas(32) double lanes[4][8][4];
    for (int m = 0; m < 4; ++m)
      for (int h = 0; h < 2; ++h) {
        const double* rows = table[kMatrices + 9 * m + 4 * h];
        const D4 r0 = *reinterpret_cast<const D4*>(rows), r1 = *reinterpret_cast<const D4*>(rows + 4);
        const D4 r2 = *reinterpret_cast<const D4*>(rows + 8), r3 = *reinterpret_cast<const D4*>(rows + 12);
        const D4 t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6), t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
        const D4 t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6), t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
        *reinterpret_cast<D4*>(lanes[0][2 * m + h]) = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
        *reinterpret_cast<D4*>(lanes[1][2 * m + h]) = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
        *reinterpret_cast<D4*>(lanes[2][2 * m + h]) = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
        *reinterpret_cast<D4*>(lanes[3][2 * m + h]) = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
      }
    // In triangle order: scatter the vertex terms, write the blocks.
    for (int l = 0; l < 4; ++l) {
      const PackedTriangle& t = *tr[l];
      for (int i = 0; i < 3; ++i)
        for (int c = 0; c < 3; ++c) {
          F[o[i][l] + c] -= table[kForce + 3 * i + c][l];
          KW[o[i][l] + c] -= table[kStiffness + 3 * i + c][l];
        }
      const auto entries = [&](int k) {
        return Eigen::Array4d(Eigen::Map<const Eigen::Array4d, Eigen::Aligned32>(lanes[l][k]));
      };
      TriangleMatrices M;
      M.uu_lo = entries(0);
      M.uu_hi = entries(1);
      M.uv_lo = entries(2);
      M.uv_hi = entries(3);
      M.vu_lo = entries(4);
      M.vu_hi = entries(5);
      M.vv_lo = entries(6);
      M.vv_hi = entries(7);
      M.uu_8 = table[kMatrices + 8][l];
      M.x_8 = table[kMatrices + 9 + 8][l];
      M.vv_8 = table[kMatrices + 27 + 8][l];
      write_triangle_blocks(t, t.ru, t.rv, M, blocks, c_.bending_only_slots.data(), q, qd, ck, cd);
    }
  }
}

void ClothSystem::assemble_step(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) {
  assemble_step_kernel(x, v, w, out);
}

WEFT_HOT_KERNEL void ClothSystem::assemble_nodes(const VecX& x, const VecX& v, const VecX& w, int begin, int end,
                                                  StepAssembly& out) const {
  // Per vertex: gravity and the bending forces, energy, viscous power and K w. Summed over
  // the stencils, Q and gamma Q live on the block pattern (bending_slot_q and
  // c_.bending_slot_damping): E = 1/2 sum_ij Q_ij x_i . x_j; F = -Q x - gamma Q v; K = -Q (x) I3;
  // D = -gamma Q (x) I3. This pass assigns force and K w; the membranes add to them.
  const int n = num_nodes();
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  const double* q = model_.bending_slot_q.data();
  const double* qd = c_.bending_slot_damping.data();
  const double* X = x.data();
  const double* Vel = v.data();
  const double* W = w.data();
  double* F = out.force.data();
  double* KW = out.stiffness_times_w.data();
  const Vec3& g = model_.gravity;
  const bool bending = !model_.bending.empty();
  for (int i = begin; i < end; ++i) {
    const double mi = model_.mass[i];
    const double* xi = X + 3 * i;
    double qx[3] = {0, 0, 0}, qv[3] = {0, 0, 0}, qw[3] = {0, 0, 0};
    double bending_energy = 0, bending_power = 0;
    if (bending) {
      D4 sx = splat(0), sv = splat(0), sw = splat(0);  // four-wide, lane 3 unused
      for (int s = rs[i]; s < rs[i + 1]; ++s) {
        const int j = col[s];
        if (j + 1 < n) {
          sx += q[s] * node_values<true>(X, j);
          sv += qd[s] * node_values<true>(Vel, j);
          sw += q[s] * node_values<true>(W, j);
        } else {  // the last node
          sx += q[s] * node_values<false>(X, j);
          sv += qd[s] * node_values<false>(Vel, j);
          sw += q[s] * node_values<false>(W, j);
        }
      }
      for (int c = 0; c < 3; ++c) {
        qx[c] = sx[c];
        qv[c] = sv[c];
        qw[c] = sw[c];
      }
      bending_energy = 0.5 * (xi[0] * qx[0] + xi[1] * qx[1] + xi[2] * qx[2]);
      bending_power = -(Vel[3 * i] * qv[0] + Vel[3 * i + 1] * qv[1] + Vel[3 * i + 2] * qv[2]);
    }
    d_.node_gravity[i] = -mi * (g[0] * xi[0] + g[1] * xi[1] + g[2] * xi[2]);
    d_.node_bending[i] = bending_energy;
    d_.node_bending_power[i] = bending_power;
    for (int c = 0; c < 3; ++c) {
      F[3 * i + c] = mi * g[c] - (qx[c] + qv[c]);
      KW[3 * i + c] = -qw[c];
    }
  }
}

template <class Piece>
void ClothSystem::for_each_membrane_piece(const Piece& piece) const {
  const auto& pieces = c_.membrane_pieces;
  const auto& groups = c_.membrane_groups;
  for (size_t g = 0; g + 1 < groups.size(); ++g)
    parallel_chunks(static_cast<size_t>(groups[g + 1] - groups[g]), [&](size_t k) {
      const auto& [begin, end] = pieces[groups[g] + k];
      piece(static_cast<size_t>(begin), static_cast<size_t>(end));
    });
}

void ClothSystem::assemble_step_kernel(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) {
  const int n = num_nodes();
  const bool jacobians = out.ck != 0.0 || out.cd != 0.0;
  out.force.resize(3 * n);
  out.stiffness_times_w.resize(3 * n);
  if (out.matrix.pattern != &model_.pattern) out.matrix.reset(model_.pattern);
  d_.node_gravity.resize(n);
  d_.node_bending.resize(n);
  d_.node_bending_power.resize(n);
  // The nodes in pieces of kNodePiece; every sum below is taken in index order afterwards, so
  // the energies are the same at every thread count (and those a serial loop gives).
  constexpr int kNodePiece = 1024;
  parallel_chunks(static_cast<size_t>((n + kNodePiece - 1) / kNodePiece), [&](size_t k) {
    const int begin = static_cast<int>(k) * kNodePiece;
    assemble_nodes(x, v, w, begin, std::min(n, begin + kNodePiece), out);
  });
  const bool bending = !model_.bending.empty();
  double gravity_energy = 0, bending_energy = 0, bending_power = 0;
  for (int i = 0; i < n; ++i) {
    if (bending) {
      bending_energy += d_.node_bending[i];
      bending_power += d_.node_bending_power[i];
    }
    gravity_energy += d_.node_gravity[i];
  }
  out.gravity_energy = gravity_energy;
  out.elastic_energy = 0;
  out.viscous_power = 0;
  if (!jacobians) {
    out.matrix.set_zero();
  } else {
    // The blocks only bending couples are rewritten below with the same values unless ck or
    // cd changed (or something else changed the matrix since the last assembly).
    out.matrix.constant_slots = &c_.constant_slots;
    if (out.matrix.constant_version != d_.constants_version || out.ck != d_.constants_ck || out.cd != d_.constants_cd) {
      out.matrix.constants_changed();
      d_.constants_version = out.matrix.constant_version;
      d_.constants_ck = out.ck;
      d_.constants_cd = out.cd;
    }
  }
  const size_t count = c_.triangles.size();
  const size_t batched = count - count % 4;
  d_.triangle_energy.resize(count);
  d_.triangle_power.resize(count);
  // The membranes: the pieces group by group (Constants::membrane_pieces), then the last
  // count % 4 triangles.
  const auto membranes = [&](auto linear, auto mixed, bool four_wide) {
    for_each_membrane_piece([&](size_t begin, size_t end) {
      if (four_wide)
        assemble_membranes_batched<decltype(mixed)::value>(x, v, w, begin, end, out);
      else
        assemble_membranes<decltype(linear)::value, decltype(mixed)::value>(x, v, w, jacobians, begin, end, out);
    });
    assemble_membranes<decltype(linear)::value, decltype(mixed)::value>(x, v, w, jacobians, batched, count, out);
  };
  using True = std::true_type;
  using False = std::false_type;
  const bool four_wide = c_.linear_moduli && jacobians;
  if (four_wide) out.element_data.resize(6 * batched);
  else out.element_data.clear();
  if (c_.linear_moduli) {
    if (c_.mixed) membranes(True{}, True{}, four_wide);
    else membranes(True{}, False{}, four_wide);
  } else {
    if (c_.mixed) membranes(False{}, True{}, false);
    else membranes(False{}, False{}, false);
  }
  // The sums in the order a serial pass took them: the four-wide batches lane by lane, then
  // the last triangles one by one (or all one by one).
  double energy = 0, power = 0;
  size_t t = 0;
  if (four_wide) {
    D4 energy4 = splat(0), power4 = splat(0);
    for (; t < batched; t += 4) {
      energy4 += D4{d_.triangle_energy[t], d_.triangle_energy[t + 1], d_.triangle_energy[t + 2], d_.triangle_energy[t + 3]};
      power4 += D4{d_.triangle_power[t], d_.triangle_power[t + 1], d_.triangle_power[t + 2], d_.triangle_power[t + 3]};
    }
    out.elastic_energy += (energy4[0] + energy4[1]) + (energy4[2] + energy4[3]);
    out.viscous_power += (power4[0] + power4[1]) + (power4[2] + power4[3]);
  }
  for (; t < count; ++t) {
    energy += d_.triangle_energy[t];
    power += d_.triangle_power[t];
  }
  out.elastic_energy += energy;
  out.viscous_power += power;
  out.elastic_energy += bending_energy;
  out.viscous_power += bending_power;
}

double ClothSystem::viscous_power(const VecX& x, const VecX& v) { return viscous_power_with(x, v, nullptr); }

double ClothSystem::step_viscous_power(const VecX& x, const VecX& v, const StepAssembly& assembly) {
  const size_t count = c_.triangles.size();
  const bool stored = assembly.element_data.size() == 6 * (count - count % 4) && count >= 4;
  return viscous_power_with(x, v, stored ? assembly.element_data.data() : nullptr);
}

WEFT_HOT_KERNEL double ClothSystem::viscous_power_with(const VecX& x, const VecX& v, const double* frames) const {
  const double* X = x.data();
  const double* Vel = v.data();
  // Four triangles at a time (TriangleBatch), the rest one at a time.
  const size_t count = c_.triangles.size(), batched = count - count % 4;
  D4 power4 = splat(0);
  for (size_t t0 = 0; t0 < batched; t0 += 4) {
    const PackedTriangle* tr[4] = {&c_.triangles[t0], &c_.triangles[t0 + 1], &c_.triangles[t0 + 2], &c_.triangles[t0 + 3]};
    const TriangleBatch batch(tr);
    D4 U[3], V[3], Ud[3], Vd[3];
    if (frames) {  // the assembly's U and V: the same sums of the same positions
      const D4* frame = reinterpret_cast<const D4*>(frames + 6 * t0);
      for (int c = 0; c < 3; ++c) {
        U[c] = frame[c];
        V[c] = frame[3 + c];
      }
    } else {
      batch.gradient(X, U, V);
    }
    batch.gradient(Vel, Ud, Vd);
    power4 += membrane::viscous_power(batch.A, TriangleBatch::viscosity(d_.membrane_viscosity.data(), t0),
                                      membrane::strain_rate(U, V, Ud, Vd));
  }
  double power = (power4[0] + power4[1]) + (power4[2] + power4[3]);
  for (size_t t = batched; t < count; ++t) {
    const PackedTriangle& tr = c_.triangles[t];
    const int o[3] = {3 * tr.vertex[0], 3 * tr.vertex[1], 3 * tr.vertex[2]};
    double U[3], V[3], Ud[3], Vd[3];
    membrane::gradient(tr.ru, tr.rv, [&](int k, int c) { return X[o[k] + c]; }, U, V);
    membrane::gradient(tr.ru, tr.rv, [&](int k, int c) { return Vel[o[k] + c]; }, Ud, Vd);
    const Vec3& eta = d_.membrane_viscosity[t];
    power += membrane::viscous_power(tr.area, membrane::Modes<double>{eta[0], eta[1], eta[2]},
                                     membrane::strain_rate(U, V, Ud, Vd));
  }
  if (model_.bending.empty()) return power;
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  const double* qd = c_.bending_slot_damping.data();
  const int n = num_nodes();
  // v . gamma Q v from the lower half of the symmetric gamma Q (a row's columns are sorted,
  // so the slots before the diagonal's are those of earlier nodes, each with a next node).
  for (int i = 0; i < n; ++i) {
    const int d = model_.pattern.diagonal_slot(i);
    D4 qv = splat(0);  // lane 3 unused
    for (int s = rs[i]; s < d; ++s) qv += qd[s] * node_values<true>(Vel, col[s]);
    const double* vi = Vel + 3 * i;
    power -= 2 * (vi[0] * qv[0] + vi[1] * qv[1] + vi[2] * qv[2]) + qd[d] * (vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2]);
  }
  return power;
}

// The energies of evaluate without its forces: the same expressions summed in the same order
// (gravity, then the membranes in triangle order, then the bending stencils node by node), so
// the same numbers.
void ClothSystem::potential_energy(const VecX& x, double& elastic, double& gravity) {
  using namespace membrane;
  elastic = gravity = 0;
  for (int i = 0; i < num_nodes(); ++i) gravity -= model_.mass[i] * model_.gravity.dot(node(x, i));
  for (size_t t = 0; t < model_.membranes.size(); ++t) {
    const MembraneGeometry& g = model_.membranes[t];
    const auto& tri = model_.mesh.triangles[t];
    const double ru[3] = {g.ru[0], g.ru[1], g.ru[2]}, rv[3] = {g.rv[0], g.rv[1], g.rv[2]};
    double U[3], V[3];
    gradient(ru, rv, [&](int k, int c) { return x[3 * tri[k] + c]; }, U, V);
    elastic += strain_energy(MaterialCurves(model_.material_of(t)), g.area, green_strain(U, V));
  }
  if (model_.bending.empty()) return;
  const auto& rs = model_.pattern.row_start();
  const auto& col = model_.pattern.column();
  const double* q = model_.bending_slot_q.data();
  for (int i = 0; i < num_nodes(); ++i) {
    Vec3 qx = Vec3::Zero();
    for (int s = rs[i]; s < rs[i + 1]; ++s) qx += q[s] * node(x, col[s]);
    elastic += 0.5 * node(x, i).dot(qx);
  }
}

void ClothSystem::evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) {
  const int n = num_nodes();
  // The Jacobian matrices are allocated on the first evaluation that asks for them (an
  // evaluation of forces and energies only never needs them).
  out.force.resize(3 * n);
  if (jacobians && (out.stiffness.pattern != &model_.pattern || out.damping.pattern != &model_.pattern)) prepare(out);
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
  add_bending(x, v, jacobians, out.force, out.elastic_energy, out.viscous_power, &out.stiffness, &out.damping);
}

}  // namespace weft
