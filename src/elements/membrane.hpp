#pragma once
// The anisotropic triangle membrane of METHOD.md section 5 with strain-rate viscosity.
// Vertex i has pattern coordinates (u_i, v_i) (weft, warp). The deformation gradient columns
// are U = sum_i r_u,i x_i and V = sum_i r_v,i x_i; Green strains e_uu = (U.U - 1)/2,
// e_vv = (V.V - 1)/2, e_uv = U.V; stresses s_m from the material curves; energy
// A (W_uu(e_uu) + W_vv(e_vv) + W_uv(e_uv) + C e_uu e_vv).
#include <array>

#include "weft/material.hpp"
#include "weft/types.hpp"

namespace weft {

/// Rest-state data of one triangle, computed from pattern coordinates.
struct MembraneGeometry {
  Vec3 ru, rv;       ///< r_u,i and r_v,i (1/m)
  double area = 0;   ///< rest area A (m^2)
};

/// Fails (returns false) for a degenerate pattern triangle.
bool make_membrane_geometry(const Vec2& pa, const Vec2& pb, const Vec2& pc, MembraneGeometry& g);

/// Vertex pairs (i, j), i <= j, of a triangle's Jacobian blocks.
constexpr int kMembranePairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};

/// A triangle's Jacobians in factored form. For pair p = (i, j):
///   d f_i / d x_j = -A (k0 UU^T + k1 VV^T + k2 UV^T + k3 VU^T + k4 I),
///   d f_i / d v_j = -A (e0 UU^T + e1 VV^T + e2 UV^T + e3 VU^T),
/// with k = stiffness[p], e = damping[p]; block (j, i) is the transpose of block (i, j).
struct MembraneJacobian {
  Vec3 U, V;
  double area = 0;
  std::array<std::array<double, 5>, 6> stiffness;
  std::array<std::array<double, 4>, 6> damping;
  /// The moduli the stiffness was formed from: material tangents (weft, warp, shear, the
  /// weft-warp coupling) and the stress matrix [[s_uu, s_uv], [s_uv, s_vv]], after the
  /// projection that keeps the stiffness semi-definite.
  double tu = 0, tv = 0, ts = 0, tc = 0, s00 = 0, s11 = 0, s01 = 0;
  /// -(ck d f_i/d x_j + cd d f_i/d v_j): block (i, j) of the step matrix contribution.
  Mat3 block(int p, double ck, double cd) const;
  /// (K w)_i = sum_j (d f_i / d x_j) w_j for the triangle with geometry `g`, as the
  /// directional derivative of the force along w (no 3x3 blocks formed).
  void stiffness_times(const MembraneGeometry& g, const std::array<Vec3, 3>& w,
                       std::array<Vec3, 3>& out) const;
};

struct MembraneResult {
  double energy = 0;
  Eigen::Matrix<double, 9, 1> force;     ///< elastic + viscous
  Eigen::Matrix<double, 9, 9> stiffness; ///< d force / d x (elastic part)
  Eigen::Matrix<double, 9, 9> damping;   ///< d force / d v
  double viscous_power = 0;              ///< viscous force . v
  Vec3 strain;                           ///< (e_uu, e_vv, e_uv)
  MembraneJacobian jacobian;             ///< factored Jacobians (when requested)
};

/// Evaluates one triangle. `viscosity` holds the strain-rate viscosity (N s/m) of the
/// three modes (weft, warp, shear). With `definite` the stiffness is projected to be
/// negative semi-definite (compressed membranes, METHOD.md 1); without, it is the exact
/// Jacobian of the elastic force. With `expand` false only the factored form is filled.
void evaluate_membrane(const MembraneGeometry& g, const Material& m, const Vec3& viscosity,
                       const std::array<Vec3, 3>& x, const std::array<Vec3, 3>& v,
                       bool jacobians, bool definite, MembraneResult& out, bool expand = true);

/// project_positive_2x2 for a matrix that is not positive semi-definite.
void project_indefinite_2x2(double& a, double& b, double& c);

/// Replaces the symmetric 2x2 matrix [[a, c], [c, b]] by its positive semi-definite part.
inline void project_positive_2x2(double& a, double& b, double& c) {
  if (a >= 0 && b >= 0 && a * b >= c * c) return;
  project_indefinite_2x2(a, b, c);
}

/// Tangent stiffness per mode (N/m) at the given strains: (weft, warp, shear).
Vec3 membrane_tangent_moduli(const Material& m, const Vec3& strain);

}  // namespace weft
