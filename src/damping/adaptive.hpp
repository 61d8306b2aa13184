#pragma once
// Stiffness factors and adaptive damping (docs/method.md 4, paper 2.3-2.4). For an element of
// stiffness k, viscosity l and mass m, kappa = k dt^2 / m and lambda = l dt / m; the
// damping ratio is lambda / (2 sqrt(kappa)). Adaptive damping raises each element's
// strain-rate viscosity so that its damping ratio is at least a target zeta.
#include <array>
#include <utility>
#include <vector>

#include "weft/statistics.hpp"
#include "weft/types.hpp"

namespace weft {

/// Spring (docs/method.md 4): kappa = dt^2 k / m_r and lambda = dt l / m_r with the reduced mass
/// m_r = m1 m2 / (m1 + m2), i.e. 1/m_r = 1/m1 + 1/m2 (a fixed end has 1/m = 0). This is
/// exactly dt^2 times the largest eigenvalue of M^-1/2 K_e M^-1/2 for the spring's axial stiffness.
double spring_kappa(double stiffness, double inverse_mass_1, double inverse_mass_2, double dt);
double spring_lambda(double viscosity, double inverse_mass_1, double inverse_mass_2, double dt);

/// Mass sums S = (sum r_u,i^2 / m_i, sum r_v,i^2 / m_i, sum (r_u,i^2 + r_v,i^2) / m_i) of a
/// triangle (weft, warp, shear modes); a fixed vertex has 1/m = 0.
Vec3 membrane_mass_sums(const Vec3& ru, const Vec3& rv, const Vec3& inverse_mass);

/// kappa per mode: dt^2 A E_mode S_mode.
Vec3 membrane_kappa(double area, const Vec3& tangent_moduli, const Vec3& mass_sums, double dt);
/// lambda per mode: dt A eta_mode S_mode.
Vec3 membrane_lambda(double area, const Vec3& viscosity, const Vec3& mass_sums, double dt);

/// Viscosity per mode needed for damping ratio zeta: eta >= 2 zeta sqrt(E / (A S)).
Vec3 membrane_required_viscosity(double area, const Vec3& tangent_moduli, const Vec3& mass_sums,
                                 double damping_ratio);



}  // namespace weft
