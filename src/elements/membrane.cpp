#include "elements/membrane.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace weft {

bool make_membrane_geometry(const Vec2& pa, const Vec2& pb, const Vec2& pc, MembraneGeometry& g) {
  // METHOD.md 5: d = u_a (v_b - v_c) + u_b (v_c - v_a) + u_c (v_a - v_b)
  const double d = pa.x() * (pb.y() - pc.y()) + pb.x() * (pc.y() - pa.y()) + pc.x() * (pa.y() - pb.y());
  const double scale = (pb - pa).squaredNorm() + (pc - pa).squaredNorm();
  if (!(std::abs(d) > 1e-12 * scale) || !std::isfinite(d)) return false;
  g.ru = Vec3(pb.y() - pc.y(), pc.y() - pa.y(), pa.y() - pb.y()) / d;
  g.rv = Vec3(pc.x() - pb.x(), pa.x() - pc.x(), pb.x() - pa.x()) / d;
  g.area = std::abs(d) / 2;
  return true;
}

Mat3 MembraneJacobian::block(int p, double ck, double cd) const {
  const auto& w = stiffness[p];
  const auto& e = damping[p];
  const double a = area * (ck * w[0] + cd * e[0]), b = area * (ck * w[1] + cd * e[1]);
  const double c = area * (ck * w[2] + cd * e[2]), d = area * (ck * w[3] + cd * e[3]);
  // a UU^T + b VV^T + c UV^T + d VU^T = (a U + d V) U^T + (b V + c U) V^T
  const Vec3 p_u = a * U + d * V, p_v = b * V + c * U;
  Mat3 out = p_u * U.transpose() + p_v * V.transpose();
  out.diagonal().array() += area * ck * w[4];
  return out;
}

void MembraneJacobian::stiffness_times(const MembraneGeometry& g, const std::array<Vec3, 3>& w,
                                       std::array<Vec3, 3>& out) const {
  // dU = sum_j r_u,j w_j and dV = sum_j r_v,j w_j move the strains by
  // (U.dU, V.dV, U.dV + V.dU); the force changes through the stresses (tangent moduli)
  // and through U and V themselves (stress matrix).
  const Vec3 dU = g.ru[0] * w[0] + g.ru[1] * w[1] + g.ru[2] * w[2];
  const Vec3 dV = g.rv[0] * w[0] + g.rv[1] * w[1] + g.rv[2] * w[2];
  const double a = U.dot(dU), b = V.dot(dV), c = U.dot(dV) + V.dot(dU);
  const double du = tu * a + tc * b, dv = tv * b + tc * a, ds = ts * c;
  const Vec3 gu = s00 * dU + s01 * dV, gv = s11 * dV + s01 * dU;
  for (int i = 0; i < 3; ++i)
    out[i] = -area * ((g.ru[i] * du + g.rv[i] * ds) * U + (g.rv[i] * dv + g.ru[i] * ds) * V + g.ru[i] * gu +
                      g.rv[i] * gv);
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
  const Vec3 U = g.ru[0] * x[0] + g.ru[1] * x[1] + g.ru[2] * x[2];
  const Vec3 V = g.rv[0] * x[0] + g.rv[1] * x[1] + g.rv[2] * x[2];
  const Vec3 Ud = g.ru[0] * v[0] + g.ru[1] * v[1] + g.ru[2] * v[2];
  const Vec3 Vd = g.rv[0] * v[0] + g.rv[1] * v[1] + g.rv[2] * v[2];
  const double euu = 0.5 * (U.dot(U) - 1), evv = 0.5 * (V.dot(V) - 1), euv = U.dot(V);
  out.strain = Vec3(euu, evv, euv);
  const double C = m.coupling_modulus();
  const double suu = m.weft.stress(euu) + C * evv;
  const double svv = m.warp.stress(evv) + C * euu;
  const double suv = m.shear.stress(euv);
  out.energy = g.area * (m.weft.energy(euu) + m.warp.energy(evv) + m.shear.energy(euv) + C * euu * evv);

  // Strain rates and viscous stresses (METHOD.md 5: s_visc = eta * strain rate).
  const Vec3 rate(U.dot(Ud), V.dot(Vd), U.dot(Vd) + V.dot(Ud));
  const Vec3 sv = viscosity.cwiseProduct(rate);
  out.viscous_power = -g.area * sv.dot(rate);

  // g_i = (r_u,i U, r_v,i V, r_u,i V + r_v,i U): gradients of the three strains.
  const double fu = suu + sv[0], fv = svv + sv[1], fs = suv + sv[2];
  for (int i = 0; i < 3; ++i)
    out.force.segment<3>(3 * i) = -g.area * ((fu * g.ru[i] + fs * g.rv[i]) * U + (fv * g.rv[i] + fs * g.ru[i]) * V);
  if (!jacobians) return;

  // Material tangent d s / d e: diagonal (weft, warp, shear) plus the weft-warp coupling C;
  // geometric stress matrix S = [[s_uu, s_uv], [s_uv, s_vv]].
  double tu = m.weft.tangent(euu), tv = m.warp.tangent(evv), ts = m.shear.tangent(euv), tc = C;
  double s00 = suu, s11 = svv, s01 = suv;
  if (definite) {
    // Keep the Hessian positive semi-definite: clamp the tangent and project S onto its
    // positive part (compressed membranes otherwise make the step matrix indefinite).
    tu = std::max(tu, 0.0);
    tv = std::max(tv, 0.0);
    ts = std::max(ts, 0.0);
    const double cmax = std::sqrt(tu * tv);
    tc = std::clamp(tc, -cmax, cmax);
    project_positive_2x2(s00, s11, s01);
  }
  // With g as above, sum_ab T_ab g_i,a g_j,b^T expands into the four outer products
  // UU^T, VV^T, UV^T and VU^T with scalar weights; the same holds for the viscosity.
  const double eu = viscosity[0], ev = viscosity[1], es = viscosity[2];
  MembraneJacobian& J = out.jacobian;
  J.U = U;
  J.V = V;
  J.area = g.area;
  J.tu = tu;
  J.tv = tv;
  J.ts = ts;
  J.tc = tc;
  J.s00 = s00;
  J.s11 = s11;
  J.s01 = s01;
  for (int p = 0; p < 6; ++p) {
    const int i = kMembranePairs[p][0], j = kMembranePairs[p][1];
    const double uu = g.ru[i] * g.ru[j], vv = g.rv[i] * g.rv[j];
    const double uv = g.ru[i] * g.rv[j], vu = g.rv[i] * g.ru[j];
    J.stiffness[p] = {tu * uu + ts * vv, tv * vv + ts * uu, tc * uv + ts * vu, tc * vu + ts * uv,
                      s00 * uu + s11 * vv + s01 * (uv + vu)};
    J.damping[p] = {eu * uu + es * vv, ev * vv + es * uu, es * vu, es * uv};
  }
  if (!expand) return;
  for (int p = 0; p < 6; ++p) {
    const int i = kMembranePairs[p][0], j = kMembranePairs[p][1];
    const Mat3 K = J.block(p, 1.0, 0.0), D = J.block(p, 0.0, 1.0);
    out.stiffness.block<3, 3>(3 * i, 3 * j) = -K;
    out.damping.block<3, 3>(3 * i, 3 * j) = -D;
    out.stiffness.block<3, 3>(3 * j, 3 * i) = -K.transpose();
    out.damping.block<3, 3>(3 * j, 3 * i) = -D.transpose();
  }
}

}  // namespace weft
