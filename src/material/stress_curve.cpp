// Stress-strain curves of the membrane (docs/method.md section 5): linear, or monotone
// piecewise-cubic Hermite splines (Fritsch & Carlson 1980, SIAM J. Numer. Anal. 17(2)) through
// tabulated points, with linear extrapolation and an exact energy integral.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "weft/error.hpp"
#include "weft/material.hpp"

namespace weft {

namespace {

std::string num(double x) {
  std::ostringstream s;
  s.precision(10);
  s << x;
  return s.str();
}

/// Checks a (strain, stress) table: same length, >= 2 points, finite values, strain strictly
/// monotone (increasing, or also decreasing when `allow_decreasing`).
void check_table(const std::vector<double>& x, const std::vector<double>& y,
                 const std::string& where, bool allow_decreasing) {
  if (x.empty()) throw InputError(where + ".strain: the table is empty");
  if (x.size() != y.size()) {
    throw InputError(where + ": strain has " + std::to_string(x.size()) +
                     " points but stress has " + std::to_string(y.size()));
  }
  if (x.size() < 2) throw InputError(where + ".strain: a table needs at least 2 points");
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) {
      throw InputError(where + ".strain: strain[" + std::to_string(i) + "] is not finite");
    }
    if (!std::isfinite(y[i])) {
      throw InputError(where + ".stress: stress[" + std::to_string(i) + "] is not finite");
    }
  }
  const bool decreasing = allow_decreasing && x.back() < x.front();
  for (std::size_t i = 1; i < x.size(); ++i) {
    const bool ok = decreasing ? x[i] < x[i - 1] : x[i] > x[i - 1];
    if (!ok) {
      throw InputError(where + ".strain: must be strictly " +
                       (allow_decreasing ? std::string("monotone") : std::string("increasing")) +
                       ", but strain[" + std::to_string(i - 1) + "] = " + num(x[i - 1]) +
                       " is followed by strain[" + std::to_string(i) + "] = " + num(x[i]));
    }
  }
}

/// Three-point end slope of Fritsch-Carlson/pchip, kept shape-preserving: zero if it points
/// against the end secant, at most three times the end secant if the data turn.
double end_slope(double h0, double h1, double d0, double d1) {
  double m = ((2.0 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
  if (m * d0 <= 0.0) return 0.0;
  if (d0 * d1 < 0.0 && std::abs(m) > std::abs(3.0 * d0)) return 3.0 * d0;
  return m;
}

// Cubic Hermite basis on t in [0, 1] and its antiderivatives from 0.
struct Hermite {
  double h00, h10, h01, h11;
};
Hermite basis(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + t, -2 * t3 + 3 * t2, t3 - t2};
}
Hermite basis_derivative(double t) {
  const double t2 = t * t;
  return {6 * t2 - 6 * t, 3 * t2 - 4 * t + 1, -6 * t2 + 6 * t, 3 * t2 - 2 * t};
}
Hermite basis_integral(double t) {
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t;
  return {t4 / 2 - t3 + t, t4 / 4 - 2 * t3 / 3 + t2 / 2, -t4 / 2 + t3, t4 / 4 - t3 / 3};
}

}  // namespace

StressCurve StressCurve::linear(double modulus_N_m) {
  StressCurve c;
  c.modulus_ = modulus_N_m;
  return c;
}

StressCurve StressCurve::tabulated(std::vector<double> strain, std::vector<double> stress_N_m,
                                   const std::string& where) {
  check_table(strain, stress_N_m, where, false);
  StressCurve c;
  const std::size_t n = strain.size();
  std::vector<double> h(n - 1), d(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    h[k] = strain[k + 1] - strain[k];
    d[k] = (stress_N_m[k + 1] - stress_N_m[k]) / h[k];
  }
  c.slope_.assign(n, d[0]);
  if (n > 2) {
    // Interior slopes: weighted harmonic mean of the neighbouring secants (Fritsch-Butland
    // form of Fritsch-Carlson), zero at a local extremum. Keeps each segment monotone.
    for (std::size_t k = 1; k + 1 < n; ++k) {
      if (d[k - 1] * d[k] <= 0.0) {
        c.slope_[k] = 0.0;
      } else {
        const double w1 = 2.0 * h[k] + h[k - 1], w2 = h[k] + 2.0 * h[k - 1];
        c.slope_[k] = (w1 + w2) / (w1 / d[k - 1] + w2 / d[k]);
      }
    }
    c.slope_[0] = end_slope(h[0], h[1], d[0], d[1]);
    c.slope_[n - 1] = end_slope(h[n - 2], h[n - 3], d[n - 2], d[n - 3]);
  }
  c.strain_ = std::move(strain);
  c.stress_ = std::move(stress_N_m);
  c.energy_at_knot_.assign(n, 0.0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    // Exact integral of the Hermite cubic over the whole segment.
    c.energy_at_knot_[k + 1] =
        c.energy_at_knot_[k] +
        h[k] * (0.5 * (c.stress_[k] + c.stress_[k + 1]) +
                h[k] * (c.slope_[k] - c.slope_[k + 1]) / 12.0);
  }
  c.energy_offset_ = c.integral_from_first_knot(0.0);
  c.modulus_ = c.tangent(0.0);
  return c;
}

StressCurve StressCurve::odd_symmetric(std::vector<double> strain, std::vector<double> stress_N_m,
                                       const std::string& where) {
  check_table(strain, stress_N_m, where, false);
  if (strain.front() < 0.0) {
    throw InputError(where + ".strain: a table mirrored to negative strain must start at " +
                     "strain >= 0, got " + num(strain.front()));
  }
  if (strain.front() == 0.0 && stress_N_m.front() != 0.0) {
    throw InputError(where + ".stress: a table mirrored to negative strain needs stress 0 at " +
                     "strain 0, got " + num(stress_N_m.front()));
  }
  if (strain.front() > 0.0) {
    strain.insert(strain.begin(), 0.0);
    stress_N_m.insert(stress_N_m.begin(), 0.0);
  }
  const std::size_t n = strain.size();
  std::vector<double> x(2 * n - 1), y(2 * n - 1);
  for (std::size_t i = 0; i < n; ++i) {
    x[n - 1 + i] = strain[i];
    y[n - 1 + i] = stress_N_m[i];
    x[n - 1 - i] = -strain[i];
    y[n - 1 - i] = -stress_N_m[i];
  }
  return tabulated(std::move(x), std::move(y), where);
}

std::pair<std::vector<double>, std::vector<double>> StressCurve::average_branches(
    std::vector<double> load_strain, std::vector<double> load_stress,
    std::vector<double> unload_strain, std::vector<double> unload_stress,
    const std::string& where) {
  check_table(load_strain, load_stress, where, false);
  check_table(unload_strain, unload_stress, where + ".unload", true);
  if (unload_strain.back() < unload_strain.front()) {
    std::reverse(unload_strain.begin(), unload_strain.end());
    std::reverse(unload_stress.begin(), unload_stress.end());
  }
  const double lo = std::max(load_strain.front(), unload_strain.front());
  const double hi = std::min(load_strain.back(), unload_strain.back());
  if (!(lo < hi)) {
    throw InputError(where + ".unload.strain: the unloading branch [" + num(unload_strain.front()) +
                     ", " + num(unload_strain.back()) + "] shares no strain range with the " +
                     "loading branch [" + num(load_strain.front()) + ", " +
                     num(load_strain.back()) + "]");
  }
  std::vector<double> x{lo, hi};
  for (const auto* col : {&load_strain, &unload_strain}) {
    for (double e : *col) {
      if (e > lo && e < hi) x.push_back(e);
    }
  }
  std::sort(x.begin(), x.end());
  x.erase(std::unique(x.begin(), x.end()), x.end());
  const StressCurve load = tabulated(std::move(load_strain), std::move(load_stress), where);
  const StressCurve unload =
      tabulated(std::move(unload_strain), std::move(unload_stress), where + ".unload");
  std::vector<double> y(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    y[i] = 0.5 * (load.stress(x[i]) + unload.stress(x[i]));
  }
  return {std::move(x), std::move(y)};
}

double StressCurve::stress(double e) const {
  if (is_linear()) return modulus_ * e;
  if (e <= strain_.front()) return stress_.front() + slope_.front() * (e - strain_.front());
  if (e >= strain_.back()) return stress_.back() + slope_.back() * (e - strain_.back());
  const std::size_t k =
      std::upper_bound(strain_.begin(), strain_.end(), e) - strain_.begin() - 1;
  const double h = strain_[k + 1] - strain_[k];
  const Hermite b = basis((e - strain_[k]) / h);
  return b.h00 * stress_[k] + b.h10 * h * slope_[k] + b.h01 * stress_[k + 1] +
         b.h11 * h * slope_[k + 1];
}

double StressCurve::tangent(double e) const {
  if (is_linear()) return modulus_;
  if (e <= strain_.front()) return slope_.front();
  if (e >= strain_.back()) return slope_.back();
  const std::size_t k =
      std::upper_bound(strain_.begin(), strain_.end(), e) - strain_.begin() - 1;
  const double h = strain_[k + 1] - strain_[k];
  const Hermite b = basis_derivative((e - strain_[k]) / h);
  return (b.h00 * stress_[k] + b.h01 * stress_[k + 1]) / h + b.h10 * slope_[k] +
         b.h11 * slope_[k + 1];
}

double StressCurve::integral_from_first_knot(double e) const {
  if (e <= strain_.front()) {
    const double s = e - strain_.front();
    return stress_.front() * s + 0.5 * slope_.front() * s * s;
  }
  if (e >= strain_.back()) {
    const double s = e - strain_.back();
    return energy_at_knot_.back() + stress_.back() * s + 0.5 * slope_.back() * s * s;
  }
  const std::size_t k =
      std::upper_bound(strain_.begin(), strain_.end(), e) - strain_.begin() - 1;
  const double h = strain_[k + 1] - strain_[k];
  const Hermite b = basis_integral((e - strain_[k]) / h);
  return energy_at_knot_[k] + h * (b.h00 * stress_[k] + b.h10 * h * slope_[k] +
                                   b.h01 * stress_[k + 1] + b.h11 * h * slope_[k + 1]);
}

double StressCurve::energy(double e) const {
  if (is_linear()) return 0.5 * modulus_ * e * e;
  return integral_from_first_knot(e) - energy_offset_;
}

}  // namespace weft
