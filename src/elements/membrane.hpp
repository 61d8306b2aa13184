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

struct MembraneResult {
  double energy = 0;
  Eigen::Matrix<double, 9, 1> force;     ///< elastic + viscous
  Eigen::Matrix<double, 9, 9> stiffness; ///< d force / d x (elastic part)
  Eigen::Matrix<double, 9, 9> damping;   ///< d force / d v
  double viscous_power = 0;              ///< viscous force . v
  Vec3 strain;                           ///< (e_uu, e_vv, e_uv)
};

/// Evaluates one triangle. `viscosity` holds the strain-rate viscosity (N s/m) of the
/// three modes (weft, warp, shear). With `definite` the stiffness is projected to be
/// negative semi-definite (compressed membranes, METHOD.md 1); without, it is the exact
/// Jacobian of the elastic force.
void evaluate_membrane(const MembraneGeometry& g, const Material& m, const Vec3& viscosity,
                       const std::array<Vec3, 3>& x, const std::array<Vec3, 3>& v,
                       bool jacobians, bool definite, MembraneResult& out);

/// Replaces the symmetric 2x2 matrix [[a, c], [c, b]] by its positive semi-definite part.
void project_positive_2x2(double& a, double& b, double& c);

/// Tangent stiffness per mode (N/m) at the given strains: (weft, warp, shear).
Vec3 membrane_tangent_moduli(const Material& m, const Vec3& strain);

}  // namespace weft
