#include "damping/adaptive.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace weft {

double spring_kappa(double stiffness, double inverse_mass_1, double inverse_mass_2, double dt) {
  return dt * dt * stiffness * (inverse_mass_1 + inverse_mass_2);
}

double spring_lambda(double viscosity, double inverse_mass_1, double inverse_mass_2, double dt) {
  return dt * viscosity * (inverse_mass_1 + inverse_mass_2);
}

Vec3 membrane_mass_sums(const Vec3& ru, const Vec3& rv, const Vec3& inverse_mass) {
  const Vec3 su = ru.cwiseAbs2().cwiseProduct(inverse_mass);
  const Vec3 sv = rv.cwiseAbs2().cwiseProduct(inverse_mass);
  return Vec3(su.sum(), sv.sum(), su.sum() + sv.sum());
}

Vec3 membrane_kappa(double area, const Vec3& tangent_moduli, const Vec3& mass_sums, double dt) {
  return dt * dt * area * tangent_moduli.cwiseProduct(mass_sums);
}

Vec3 membrane_lambda(double area, const Vec3& viscosity, const Vec3& mass_sums, double dt) {
  return dt * area * viscosity.cwiseProduct(mass_sums);
}

Vec3 membrane_required_viscosity(double area, const Vec3& tangent_moduli, const Vec3& mass_sums,
                                 double damping_ratio) {
  Vec3 eta;
  for (int k = 0; k < 3; ++k) {
    const double as = area * mass_sums[k];
    eta[k] = (as > 0 && tangent_moduli[k] > 0)
                 ? 2.0 * damping_ratio * std::sqrt(tangent_moduli[k] / as)
                 : 0.0;
  }
  return eta;
}

int LogStatistics::bin_of(double value) {
  constexpr int kShift = 52 - kMantissaBits;
  constexpr std::int64_t kFirst = static_cast<std::int64_t>(1023 + kMinExponent) << kMantissaBits;
  const std::int64_t key = static_cast<std::int64_t>(std::bit_cast<std::uint64_t>(value) >> kShift) - kFirst;
  return static_cast<int>(std::clamp<std::int64_t>(key, 0, kBins - 1));
}

double LogStatistics::bin_centre(int bin) {
  constexpr int kShift = 52 - kMantissaBits;
  constexpr std::uint64_t kFirst = static_cast<std::uint64_t>(1023 + kMinExponent) << kMantissaBits;
  const double lower = std::bit_cast<double>((kFirst + bin) << kShift);
  const double upper = std::bit_cast<double>((kFirst + bin + 1) << kShift);
  return 0.5 * (lower + upper);
}

void LogStatistics::add(double value) {
  if (!(value > 0) || !std::isfinite(value)) return;
  if (count_ == 0) {
    min_ = max_ = value;
  } else {
    min_ = std::min(min_, value);
    max_ = std::max(max_, value);
  }
  sum_ += value;
  ++count_;
  ++bins_[bin_of(value)];
}

void LogStatistics::merge(const LogStatistics& o) {
  if (o.count_ == 0) return;
  if (count_ == 0) {
    *this = o;
    return;
  }
  // Every value lies in [min, max] and the bins are monotone: o's other bins are empty.
  const int last = bin_of(o.max_);
  for (int i = bin_of(o.min_); i <= last; ++i) bins_[i] += o.bins_[i];
  min_ = std::min(min_, o.min_);
  max_ = std::max(max_, o.max_);
  sum_ += o.sum_;
  count_ += o.count_;
}

LogStatistics::Snapshot LogStatistics::snapshot() const {
  Snapshot s{{}, count_, min_, max_, sum_};
  for (int i = 0; i < kBins; ++i)
    if (bins_[i]) s.bins.emplace_back(i, bins_[i]);
  return s;
}

LogStatistics LogStatistics::from_snapshot(const Snapshot& s) {
  LogStatistics r;
  for (const auto& [bin, n] : s.bins) {
    if (bin < 0 || bin >= kBins) throw std::invalid_argument("statistics bin " + std::to_string(bin) + " out of range");
    r.bins_[bin] = n;
  }
  r.count_ = s.count;
  r.min_ = s.min;
  r.max_ = s.max;
  r.sum_ = s.sum;
  return r;
}

double LogStatistics::median() const {
  if (count_ == 0) return 0.0;
  long seen = 0;
  for (size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (2 * seen >= count_) return std::clamp(bin_centre(static_cast<int>(i)), min_, max_);
  }
  return max_;
}

}  // namespace weft
