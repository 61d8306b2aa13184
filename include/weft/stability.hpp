#pragma once
// Linear stability of weft's integrators on one damped spring (docs/method.md 3, paper eq. 3-13).
//
// One mass m on a spring k with viscosity l, m p'' = -(k p + l p'), advanced with step dt.
// Everything depends on the two stiffness factors
//   kappa  = k dt^2 / m   (dimensionless stiffness),
//   lambda = l dt / m     (dimensionless viscosity),
// and the state is q = [p, p' dt]. A scheme is stable for (kappa, lambda) when the spectral
// radius of its step map is at most 1.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace weft {

/// The step matrix H of the alpha family (docs/method.md 1 and 3, paper eq. 4-5):
/// q(t + dt) = H q(t) with q = [p, p' dt]. With B = [[0, 1], [-kappa, -lambda]] and
/// D = 1 + lambda alpha + kappa alpha^2,
///   H = I + (I - alpha B)^-1 B
///     = [[1 - kappa alpha / D, 1 / D], [-kappa / D, 1 - (lambda + kappa alpha) / D]].
/// Requires D != 0 (always true for kappa, lambda >= 0 and alpha in [0, 1]).
Eigen::Matrix2d alpha_family_step_matrix(double alpha, double kappa, double lambda);

/// max |z| over the two eigenvalues z of alpha_family_step_matrix (computed from the
/// closed-form eigenvalues of a real 2x2 matrix, so it is exact up to rounding).
double alpha_family_spectral_radius(double alpha, double kappa, double lambda);

/// The 4x4 step map of progressive BDF-2 (docs/method.md 2-3, paper eq. 13) acting on
/// [q, dq], dq the previous step's change of q. With beta = (2 alpha - 1) / (2 alpha + 1),
/// c = dt_b / dt = 2 / (2 alpha + 1) and A = (I - alpha c B)^-1:
///   dq_next = A (beta dq + c B q),   q_next = q + dq_next.
Eigen::Matrix4d bdf2_step_matrix(double alpha, double kappa, double lambda);

/// Spectral radius of bdf2_step_matrix (Eigen::EigenSolver on the 4x4 map).
double bdf2_spectral_radius(double alpha, double kappa, double lambda);

/// The analytic stability conditions of the alpha family (docs/method.md 3, paper eq. 10):
///   (10a) kappa > 0,
///   (10b) lambda > (1 - 2 alpha) kappa,
///   (10c) for alpha < 1/2 only: lambda < 2 / (1 - 2 alpha) + kappa (1 - 2 alpha) / 2.
/// Valid for a non-negative viscosity (lambda >= 0), the physical case: for lambda < 0 and
/// alpha > 1/2 the Jury condition 4 - 2 (1 - 2 alpha) lambda + (1 - 2 alpha)^2 kappa > 0
/// (which (10c) expresses for alpha < 1/2) is no longer implied and (10) can say "stable"
/// for an unstable point. Strict inequalities: boundary points count as not stable.
bool alpha_family_is_stable(double alpha, double kappa, double lambda);

/// Which step map a stability map is computed for.
struct StabilityScheme {
  enum class Kind { kAlphaFamily, kProgressiveBdf2 };
  Kind kind = Kind::kAlphaFamily;
  double alpha = 0.5;  ///< in [0, 1]

  /// Spectral radius of this scheme's step map at (kappa, lambda).
  double spectral_radius(double kappa, double lambda) const;
};

/// A scheme by the name the `weft stability` command uses: forward-euler (alpha 0),
/// implicit-midpoint (1/2), backward-euler (1), alpha (alpha given), bdf2 (BDF-2,
/// alpha 1), bdf2-alpha (progressive BDF-2, alpha given or 1/sqrt(3)).
/// `alpha` is used by "alpha" (required) and "bdf2-alpha" (optional); pass NaN for "not
/// given". Throws InputError for an unknown name, a missing or unused alpha, or an alpha
/// outside [0, 1]; messages name the command-line options --method and --alpha.
StabilityScheme stability_scheme_by_name(const std::string& method, double alpha);

/// Names accepted by stability_scheme_by_name, in the order the help lists them.
const std::vector<std::string>& stability_method_names();

/// Points with spectral radius above this are unstable (white in the images).
constexpr double kStabilityTolerance = 1e-12;

/// Spectral radius sampled on a regular size x size grid:
/// kappa_i = kappa_max i / (size - 1), lambda_j = lambda_max j / (size - 1).
struct StabilityMap {
  std::vector<double> kappa;      ///< size values, increasing from 0 to kappa_max
  std::vector<double> lambda;     ///< size values, increasing from 0 to lambda_max
  Eigen::MatrixXd spectral_radius;  ///< size by size; row i is kappa_i, column j is lambda_j

  bool stable(int i, int j) const { return spectral_radius(i, j) <= 1.0 + kStabilityTolerance; }
};

/// Samples scheme.spectral_radius on the grid above. Requires kappa_max > 0,
/// lambda_max > 0 (finite) and size >= 2; throws std::invalid_argument otherwise.
/// `threads` splits the rows over that many threads (0: one per core, at most one per 64
/// rows); the result is the same bits for any thread count.
StabilityMap compute_stability_map(const StabilityScheme& scheme, double kappa_max,
                                   double lambda_max, int size, int threads = 0);

}  // namespace weft
