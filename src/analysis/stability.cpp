#include "weft/stability.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "weft/error.hpp"

namespace weft {
namespace {

/// B of docs/method.md 3: the spring's time derivative of q = [p, p' dt], scaled by dt.
Eigen::Matrix2d spring_derivative_matrix(double kappa, double lambda) {
  Eigen::Matrix2d b;
  b << 0.0, 1.0, -kappa, -lambda;
  return b;
}

std::string format_number(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

}  // namespace

Eigen::Matrix2d alpha_family_step_matrix(double alpha, double kappa, double lambda) {
  // docs/method.md 1: dq = (I - alpha dt dQ'/dQ)^-1 Q'(t) dt, which for the spring is
  // (I - alpha B)^-1 B q; det(I - alpha B) = D = 1 + lambda alpha + kappa alpha^2.
  const Eigen::Matrix2d b = spring_derivative_matrix(kappa, lambda);
  const Eigen::Matrix2d implicit = Eigen::Matrix2d::Identity() - alpha * b;
  return Eigen::Matrix2d::Identity() + implicit.inverse() * b;
}

double alpha_family_spectral_radius(double alpha, double kappa, double lambda) {
  // Closed-form eigenvalues (docs/method.md 3, paper eq. 6):
  // z = [(1 - lambda/2) + (lambda - kappa) alpha + kappa alpha^2 +- sqrt(lambda^2/4 - kappa)] / D
  const double d = 1.0 + lambda * alpha + kappa * alpha * alpha;
  const double mean = (1.0 - 0.5 * lambda) + (lambda - kappa) * alpha + kappa * alpha * alpha;
  const double discriminant = 0.25 * lambda * lambda - kappa;
  if (discriminant >= 0.0) {
    // Two real eigenvalues; the larger magnitude is |mean| + sqrt(discriminant).
    return (std::abs(mean) + std::sqrt(discriminant)) / std::abs(d);
  }
  // Complex pair: |z|^2 = (mean^2 + |discriminant|) / D^2.
  return std::hypot(mean, std::sqrt(-discriminant)) / std::abs(d);
}

Eigen::Matrix4d bdf2_step_matrix(double alpha, double kappa, double lambda) {
  // docs/method.md 2-3 (paper eq. 13): Q(t+dt) - Q(t) = beta dQ_prev + Q'(t + alpha dt) dt_b,
  // linearised: dq = (I - alpha c B)^-1 (beta dq_prev + c B q), c = dt_b / dt.
  const double beta = (2.0 * alpha - 1.0) / (2.0 * alpha + 1.0);
  const double c = 2.0 / (2.0 * alpha + 1.0);
  const Eigen::Matrix2d b = spring_derivative_matrix(kappa, lambda);
  const Eigen::Matrix2d a = (Eigen::Matrix2d::Identity() - alpha * c * b).inverse();
  Eigen::Matrix4d step;
  // Rows 2-3: dq_next = c A B q + beta A dq; rows 0-1: q_next = q + dq_next.
  step.bottomLeftCorner<2, 2>() = c * a * b;
  step.bottomRightCorner<2, 2>() = beta * a;
  step.topLeftCorner<2, 2>() = Eigen::Matrix2d::Identity() + c * a * b;
  step.topRightCorner<2, 2>() = beta * a;
  return step;
}

double bdf2_spectral_radius(double alpha, double kappa, double lambda) {
  const Eigen::EigenSolver<Eigen::Matrix4d> solver(bdf2_step_matrix(alpha, kappa, lambda),
                                                   /*computeEigenvectors=*/false);
  return solver.eigenvalues().cwiseAbs().maxCoeff();
}

bool alpha_family_is_stable(double alpha, double kappa, double lambda) {
  const double one_minus_two_alpha = 1.0 - 2.0 * alpha;
  if (!(kappa > 0.0)) return false;                        // (10a)
  if (!(lambda > one_minus_two_alpha * kappa)) return false;  // (10b)
  if (one_minus_two_alpha > 0.0 &&                          // (10c), alpha < 1/2 only
      !(lambda < 2.0 / one_minus_two_alpha + kappa * one_minus_two_alpha / 2.0))
    return false;
  return true;
}

double StabilityScheme::spectral_radius(double kappa, double lambda) const {
  return kind == Kind::kAlphaFamily ? alpha_family_spectral_radius(alpha, kappa, lambda)
                                   : bdf2_spectral_radius(alpha, kappa, lambda);
}

const std::vector<std::string>& stability_method_names() {
  static const std::vector<std::string> names{"forward-euler", "implicit-midpoint",
                                              "backward-euler", "alpha",
                                              "bdf2",          "bdf2-alpha"};
  return names;
}

StabilityScheme stability_scheme_by_name(const std::string& method, double alpha) {
  const bool alpha_given = !std::isnan(alpha);
  const bool takes_alpha = method == "alpha" || method == "bdf2-alpha";
  const auto& names = stability_method_names();
  if (std::find(names.begin(), names.end(), method) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw InputError("--method: unknown method '" + method + "' (expected one of " + list + ")");
  }
  if (alpha_given && !takes_alpha)
    throw InputError("--alpha " + format_number(alpha) + ": method '" + method +
                     "' has a fixed alpha; --alpha is only for methods alpha and bdf2-alpha");
  if (method == "alpha" && !alpha_given)
    throw InputError("--alpha: method 'alpha' needs --alpha A with A in [0, 1]");
  if (alpha_given && !(alpha >= 0.0 && alpha <= 1.0))
    throw InputError("--alpha " + format_number(alpha) + ": expected a number in [0, 1]");

  using Kind = StabilityScheme::Kind;
  if (method == "forward-euler") return {Kind::kAlphaFamily, 0.0};
  if (method == "implicit-midpoint") return {Kind::kAlphaFamily, 0.5};
  if (method == "backward-euler") return {Kind::kAlphaFamily, 1.0};
  if (method == "alpha") return {Kind::kAlphaFamily, alpha};
  if (method == "bdf2") return {Kind::kProgressiveBdf2, 1.0};
  // bdf2-alpha: the paper's low-dissipation variant by default (docs/method.md 2).
  return {Kind::kProgressiveBdf2, alpha_given ? alpha : 1.0 / std::sqrt(3.0)};
}

StabilityMap compute_stability_map(const StabilityScheme& scheme, double kappa_max,
                                   double lambda_max, int size, int threads) {
  if (!(std::isfinite(kappa_max) && kappa_max > 0.0) ||
      !(std::isfinite(lambda_max) && lambda_max > 0.0) || size < 2)
    throw std::invalid_argument("compute_stability_map: need kappa_max > 0, lambda_max > 0, size >= 2");
  StabilityMap map;
  map.kappa.resize(size);
  map.lambda.resize(size);
  for (int i = 0; i < size; ++i) {
    map.kappa[i] = kappa_max * i / (size - 1);
    map.lambda[i] = lambda_max * i / (size - 1);
  }
  map.spectral_radius.resize(size, size);
  // Every point is independent, so splitting the kappa rows over threads gives the same
  // bits for any thread count.
  const int thread_count =
      threads > 0 ? std::min(threads, size)
                  : std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, std::max(1, size / 64));
  auto fill_rows = [&](int first, int last) {
    for (int i = first; i < last; ++i)
      for (int j = 0; j < size; ++j)
        map.spectral_radius(i, j) = scheme.spectral_radius(map.kappa[i], map.lambda[j]);
  };
  std::vector<std::thread> workers;
  const int rows_per_thread = (size + thread_count - 1) / thread_count;
  for (int t = 1; t < thread_count; ++t)
    workers.emplace_back(fill_rows, std::min(size, t * rows_per_thread),
                         std::min(size, (t + 1) * rows_per_thread));
  fill_rows(0, std::min(size, rows_per_thread));
  for (auto& w : workers) w.join();
  return map;
}

}  // namespace weft
