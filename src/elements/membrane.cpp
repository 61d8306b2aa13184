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

Vec3 membrane_tangent_moduli(const Material& m, const Vec3& e) {
  return Vec3(m.weft.tangent(e[0]), m.warp.tangent(e[1]), m.shear.tangent(e[2]));
}

void evaluate_membrane(const MembraneGeometry& g, const Material& m, const Vec3& viscosity,
                       const std::array<Vec3, 3>& x, const std::array<Vec3, 3>& v,
                       bool jacobians, bool definite, MembraneResult& out) {
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
  std::array<std::array<Vec3, 3>, 3> grad;  // grad[i][mode]
  for (int i = 0; i < 3; ++i) {
    grad[i][0] = g.ru[i] * U;
    grad[i][1] = g.rv[i] * V;
    grad[i][2] = g.ru[i] * V + g.rv[i] * U;
    out.force.segment<3>(3 * i) = -g.area * ((suu + sv[0]) * grad[i][0] + (svv + sv[1]) * grad[i][1] +
                                             (suv + sv[2]) * grad[i][2]);
  }
  if (!jacobians) return;

  // Material tangent T = d s / d e (3x3) and the geometric stress matrix S = [[suu, suv], [suv, svv]].
  Mat3 T = Mat3::Zero();
  T(0, 0) = m.weft.tangent(euu);
  T(1, 1) = m.warp.tangent(evv);
  T(2, 2) = m.shear.tangent(euv);
  T(0, 1) = T(1, 0) = C;
  double s00 = suu, s11 = svv, s01 = suv;
  if (definite) {
    // Keep the Hessian positive semi-definite: clamp the tangent and project S onto its
    // positive part (compressed membranes otherwise make the step matrix indefinite).
    for (int k = 0; k < 3; ++k) T(k, k) = std::max(T(k, k), 0.0);
    const double cmax = std::sqrt(T(0, 0) * T(1, 1));
    T(0, 1) = T(1, 0) = std::clamp(C, -cmax, cmax);
    Eigen::SelfAdjointEigenSolver<Mat2> es(Mat2{{suu, suv}, {suv, svv}});
    const Vec2 lam = es.eigenvalues().cwiseMax(0.0);
    const Mat2 P = es.eigenvectors() * lam.asDiagonal() * es.eigenvectors().transpose();
    s00 = P(0, 0), s11 = P(1, 1), s01 = P(0, 1);
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      Mat3 Kij = Mat3::Zero();
      Mat3 Dij = Mat3::Zero();
      for (int a = 0; a < 3; ++a) {
        Dij.noalias() += viscosity[a] * grad[i][a] * grad[j][a].transpose();
        for (int b = 0; b < 3; ++b)
          if (T(a, b) != 0.0) Kij.noalias() += T(a, b) * grad[i][a] * grad[j][b].transpose();
      }
      const double geometric = s00 * g.ru[i] * g.ru[j] + s11 * g.rv[i] * g.rv[j] +
                               s01 * (g.ru[i] * g.rv[j] + g.rv[i] * g.ru[j]);
      Kij.diagonal().array() += geometric;
      out.stiffness.block<3, 3>(3 * i, 3 * j) = -g.area * Kij;
      out.damping.block<3, 3>(3 * i, 3 * j) = -g.area * Dij;
    }
  }
}

}  // namespace weft
