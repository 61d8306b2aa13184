#pragma once
// Linear bending element (docs/method.md 5): for the edge CD shared by triangles with tips A and B,
// R = sum_i alpha_i x_i vanishes on the flat rest shape and measures the bend;
// energy k_b |R|^2 / 2, forces F_i = -k_b alpha_i R, constant Jacobian -k_b alpha alpha^T (x) I3.
#include <array>
#include <vector>

#include "weft/types.hpp"

namespace weft {

struct BendingGeometry {
  Eigen::Vector4d alpha;  ///< coefficients of (A, B, C, D); sum to zero
  double stiffness = 0;   ///< k_b (N/m)
  double kappa_factor = 0;///< sum_i alpha_i^2 / m_i is formed by the caller; this is sum alpha^2
};

/// Builds the stencil from flat pattern coordinates of tips A, B and edge C, D.
/// The coefficients make R vanish on the pattern: alpha_A A + alpha_B B is the point where line
/// AB crosses line CD, as is -(alpha_C C + alpha_D D) (the height ratios of docs/method.md 5 when
/// ACBD is convex). `rigidity_weft_Nm`/`rigidity_warp_Nm` weigh the rigidity by the direction
/// across the edge: B = B_weft n_u^2 + B_warp n_v^2, n the unit normal of CD in the pattern.
/// Returns false for a degenerate stencil.
bool make_bending_geometry(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d,
                           double rigidity_weft_Nm, double rigidity_warp_Nm, BendingGeometry& g);

}  // namespace weft

namespace weft {

/// A linear bending element in general form: measures R_m = sum_k c_mk x_k (3D vectors)
/// that vanish on the flat rest shape and under rigid motion, with energy
/// E = 1/2 sum_m w_m |R_m|^2 = 1/2 sum_ij Q_ij x_i . x_j, Q = sum_m w_m c_m c_m^T.
/// Forces F_i = -sum_j Q_ij x_j; constant Jacobian -Q (x) I3. Damping adds -gamma Q v.
/// The hinge element above is one measure (alpha) with weight k_b.
struct LinearBendingStencil {
  std::vector<int> vertices;  ///< k vertex indices
  MatX measures;              ///< m by k coefficients c_mk
  VecX weights;               ///< m weights w_m (N/m)
  MatX Q;                     ///< k by k, sum_m w_m c_m c_m^T
  void finish() { Q = measures.transpose() * weights.asDiagonal() * measures; }
  /// sum_m w_m sum_k c_mk^2 / m_k: kappa = dt^2 times this (docs/method.md 4 per-mode bound).
  double stiffness_mass_sum(const VecX& inverse_mass) const;
};

/// The hinge element as a general stencil (vertices A, B, C, D).
LinearBendingStencil hinge_stencil(const std::array<int, 4>& vertices, const BendingGeometry& g);

}  // namespace weft
