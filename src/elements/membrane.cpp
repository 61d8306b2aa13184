#include "elements/membrane.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace weft {

bool make_membrane_geometry(const Vec2& pa, const Vec2& pb, const Vec2& pc, MembraneGeometry& g) {
  // docs/method.md 5: d = u_a (v_b - v_c) + u_b (v_c - v_a) + u_c (v_a - v_b)
  const double d = pa.x() * (pb.y() - pc.y()) + pb.x() * (pc.y() - pa.y()) + pc.x() * (pa.y() - pb.y());
  const double scale = (pb - pa).squaredNorm() + (pc - pa).squaredNorm();
  if (!(std::abs(d) > 1e-12 * scale) || !std::isfinite(d)) return false;
  g.ru = Vec3(pb.y() - pc.y(), pc.y() - pa.y(), pa.y() - pb.y()) / d;
  g.rv = Vec3(pc.x() - pb.x(), pa.x() - pc.x(), pb.x() - pa.x()) / d;
  g.area = std::abs(d) / 2;
  return true;
}

void MembraneJacobian::stiffness_times(const MembraneGeometry& g, const std::array<Vec3, 3>& w,
                                       std::array<Vec3, 3>& out) const {
  const double ru[3] = {g.ru[0], g.ru[1], g.ru[2]}, rv[3] = {g.rv[0], g.rv[1], g.rv[2]};
  double dU[3], dV[3];
  membrane::gradient(ru, rv, [&](int k, int c) { return w[k][c]; }, dU, dV);
  membrane::scatter_stiffness_times(moduli, area, ru, rv, U.data(), V.data(), dU, dV,
                                    [&](int i, int c, double value) { out[i][c] = -value; });
}

void project_indefinite_2x2(double& a, double& b, double& c) {
  // Eigenvalues l1,2 = mean +- r. With l2 < 0 < l1 the positive part is l1 e e^T, and
  // e e^T = (A - l2 I) / (l1 - l2) = [[h + r, c], [c, r - h]] / (2 r) with h = (a - b) / 2;
  // the smaller of h + r and r - h is formed as c^2 over the larger (no cancellation).
  // Stresses are far from overflow and underflow: sqrt(h^2 + c^2) needs no hypot.
  const double h = 0.5 * (a - b);
  const double mean = 0.5 * (a + b), r = std::sqrt(h * h + c * c);
  const double l1 = mean + r;  // the larger eigenvalue; the smaller one is negative here
  if (l1 <= 0 || !(r > 0)) {
    a = b = std::max(l1, 0.0);
    c = 0;
    return;
  }
  double pa, pb;
  if (h >= 0) {
    pa = h + r;
    pb = c * c / pa;
  } else {
    pb = r - h;
    pa = c * c / pb;
  }
  const double scale = l1 / (2 * r);
  a = scale * pa;
  b = scale * pb;
  c = scale * c;
}

Vec3 membrane_tangent_moduli(const Material& m, const Vec3& e) {
  return Vec3(m.weft.tangent(e[0]), m.warp.tangent(e[1]), m.shear.tangent(e[2]));
}

void evaluate_membrane(const MembraneGeometry& g, const Material& m, const Vec3& viscosity,
                       const std::array<Vec3, 3>& x, const std::array<Vec3, 3>& v,
                       bool jacobians, bool definite, MembraneResult& out, bool expand) {
  using namespace membrane;
  const double ru[3] = {g.ru[0], g.ru[1], g.ru[2]}, rv[3] = {g.rv[0], g.rv[1], g.rv[2]};
  double U[3], V[3], Ud[3], Vd[3];
  gradient(ru, rv, [&](int k, int c) { return x[k][c]; }, U, V);
  gradient(ru, rv, [&](int k, int c) { return v[k][c]; }, Ud, Vd);
  const MaterialCurves curves(m);
  const Modes<double> eta{viscosity[0], viscosity[1], viscosity[2]};
  Forces<double> f;
  forces(curves, g.area, eta, U, V, Ud, Vd, f);
  out.strain = Vec3(f.strain.uu, f.strain.vv, f.strain.uv);
  out.energy = f.energy;
  out.viscous_power = f.viscous_power;
  scatter_force(f, ru, rv, U, V, [&](int i, int c, double value) { out.force[3 * i + c] = -value; });
  if (!jacobians) return;

  Stiffness<double> k;
  if (definite) {
    k = definite_stiffness(curves, f);
  } else {  // the exact Jacobian of the elastic force
    curves.tangents(f.strain, k.tangent, k.coupling);
    k.s00 = f.stress.uu;
    k.s11 = f.stress.vv;
    k.s01 = f.stress.uv;
  }
  MembraneJacobian& J = out.jacobian;
  J.U = Vec3(U[0], U[1], U[2]);
  J.V = Vec3(V[0], V[1], V[2]);
  J.area = g.area;
  J.moduli = k;
  if (!expand) return;
  // Block (i, j) of -K and of -D from the four matrices of step_matrices.
  double mk[4][9], md[4][9];
  step_matrices(k, eta, g.area, 1.0, 0.0, U, V, mk);
  step_matrices(k, eta, g.area, 0.0, 1.0, U, V, md);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double w[4] = {ru[i] * ru[j], ru[i] * rv[j], rv[i] * ru[j], rv[i] * rv[j]};
      for (int e = 0; e < 9; ++e) {
        const int r = e % 3, c = e / 3;
        out.stiffness(3 * i + r, 3 * j + c) = -(w[0] * mk[0][e] + w[1] * mk[1][e] + w[2] * mk[2][e] + w[3] * mk[3][e]);
        out.damping(3 * i + r, 3 * j + c) = -(w[0] * md[0][e] + w[1] * md[1][e] + w[2] * md[2][e] + w[3] * md[3][e]);
      }
    }
}

}  // namespace weft
