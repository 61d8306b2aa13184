#pragma once
// Stiffness factors and adaptive damping (METHOD.md 4, paper 2.3-2.4). For an element of
// stiffness k, viscosity l and mass m, kappa = k dt^2 / m and lambda = l dt / m; the
// damping ratio is lambda / (2 sqrt(kappa)). Adaptive damping raises each element's
// strain-rate viscosity so that its damping ratio is at least a target zeta.
#include <array>
#include <utility>
#include <vector>

#include "weft/types.hpp"

namespace weft {

/// Spring (METHOD.md 4): kappa = dt^2 k / m_r and lambda = dt l / m_r with the reduced mass
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


/// Running statistics of positive values (min, max, mean and a median from a fine
/// histogram of the values' exponent and leading mantissa bits: 128 bins per octave, each
/// at most 0.8% of its value wide).
class LogStatistics {
 public:
  void add(double value);
  void merge(const LogStatistics& other);
  long count() const { return count_; }
  double min() const { return count_ ? min_ : 0.0; }
  double max() const { return count_ ? max_ : 0.0; }
  double mean() const { return count_ ? sum_ / count_ : 0.0; }
  /// Median to within half a bin (0.4% relative).
  double median() const;

  /// The exact contents (checkpoints): the non-empty bins as (bin, count) and the running
  /// values; from_snapshot throws std::invalid_argument for a bin out of range.
  struct Snapshot {
    std::vector<std::pair<int, long>> bins;
    long count = 0;
    double min = 0, max = 0, sum = 0;
  };
  Snapshot snapshot() const;
  static LogStatistics from_snapshot(const Snapshot& s);

 private:
  // A positive double's bit pattern shifted right by 52 - kMantissaBits is monotone in the
  // value: exponent times 2^kMantissaBits plus the leading mantissa bits. That is the bin,
  // so adding a value costs no logarithm.
  static constexpr int kMantissaBits = 7;
  static constexpr int kMinExponent = -60, kMaxExponent = 60;  ///< about 1e-18 to 1e18
  static constexpr int kBins = (kMaxExponent - kMinExponent) << kMantissaBits;
  static int bin_of(double value);
  static double bin_centre(int bin);
  std::vector<long> bins_ = std::vector<long>(kBins, 0);
  long count_ = 0;
  double min_ = 0, max_ = 0, sum_ = 0;
};

}  // namespace weft
