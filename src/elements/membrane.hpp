#pragma once
// The anisotropic triangle membrane of docs/method.md section 5 with strain-rate viscosity.
// Vertex i has pattern coordinates (u_i, v_i) (weft, warp). The deformation gradient columns
// are U = sum_i r_u,i x_i and V = sum_i r_v,i x_i; Green strains e_uu = (U.U - 1)/2,
// e_vv = (V.V - 1)/2, e_uv = U.V; stresses s_m from the material curves; energy
// A (W_uu(e_uu) + W_vv(e_vv) + W_uv(e_uv) + C e_uu e_vv).
#include <array>

#include "elements/membrane_kernel.hpp"
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

/// A triangle's Jacobians in factored form: the deformation gradient's columns U, V, the
/// rest area and the moduli the stiffness was formed from (membrane::Stiffness: material
/// tangents, the weft-warp coupling and the stress matrix, after the projection that keeps
/// the stiffness semi-definite when asked for).
struct MembraneJacobian {
  Vec3 U, V;
  double area = 0;
  membrane::Stiffness<double> moduli{};
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
/// negative semi-definite (compressed membranes, docs/method.md 1); without, it is the exact
/// Jacobian of the elastic force. With `expand` false only the factored form is filled.
void evaluate_membrane(const MembraneGeometry& g, const Material& m, const Vec3& viscosity,
                       const std::array<Vec3, 3>& x, const std::array<Vec3, 3>& v,
                       bool jacobians, bool definite, MembraneResult& out, bool expand = true);

/// Tangent stiffness per mode (N/m) at the given strains: (weft, warp, shear).
Vec3 membrane_tangent_moduli(const Material& m, const Vec3& strain);

}  // namespace weft
