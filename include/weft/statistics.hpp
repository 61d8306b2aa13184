#pragma once
// Statistics a run reports (summary.json): the steps and their solves, and the stiffness
// factors and added viscosity of adaptive damping.
#include <utility>
#include <vector>

namespace weft {

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

/// Per-run statistics of the stiffness factors and of the added viscosity.
struct DampingStatistics {
  LogStatistics membrane_kappa;   ///< largest mode per element and step
  LogStatistics membrane_lambda;  ///< lambda of that mode, with the viscosity used
  LogStatistics bending_kappa;
  LogStatistics added_viscosity;  ///< N s/m added over the material's, per element and step
  long element_steps = 0;         ///< membrane element-steps observed
  long raised_element_steps = 0;  ///< those whose viscosity was raised
};

struct StepStatistics {
  long steps = 0;            ///< accepted steps
  long rejected_steps = 0;   ///< RK45 rejections
  long cg_iterations = 0;
  long cg_solves = 0;
  long cg_failures = 0;      ///< solves that hit the iteration cap
  double assembly_seconds = 0;
  double solve_seconds = 0;      ///< the linear solves and their warm start (not the contacts within)
  long contacts = 0;             ///< node contacts held by linear steps (whole steps or their parts), summed
  long contact_solves = 0;       ///< linear steps (whole steps or their parts) that held contacts
  long max_contacts = 0;         ///< the most in one linear step (never below contacts / contact_solves)
  long released_contacts = 0;    ///< contacts let go because they pulled at the previous step
  long fail_safe_moves = 0;      ///< nodes moved by the contact fail-safe after a step
  long contact_passes = 0;       ///< solves repeated because nodes would have ended in a collider
  long failed_contact_steps = 0; ///< steps the contact fail-safe could not make valid
  long halved_steps = 0;         ///< steps taken again as two halves for that reason
  double detection_seconds = 0;  ///< finding contacts
  double response_seconds = 0;   ///< constraints, friction and the fail-safe
  long guard_redone_steps = 0;   ///< attempts the energy guard took again with a larger alpha
  long guard_raised_steps = 0;   ///< accepted steps taken (in part) with an alpha above the scene's
  double guard_max_alpha = 0;    ///< the largest alpha of an accepted guarded step (0: none)
  long guard_split_steps = 0;    ///< guarded steps (or parts) taken again as two halves
  long guard_futile_splits = 0;  ///< halvings given up because the first half put in as much
  long guard_parts = 0;          ///< parts the guarded steps were taken in, halvings included
  long guard_newton_steps = 0;   ///< last resorts taken again with Newton iterations (kGuardLastResortNewton)
  double guard_seconds = 0;      ///< the guard's own work: saving the start, the energy check
  long newton_iterations = 0;    ///< Newton iterations (one linear solve each) beyond the linearised step
  long newton_steps = 0;         ///< steps (or parts) that took at least one
  long newton_halvings = 0;      ///< line-search halvings
  long newton_unconverged = 0;   ///< steps that ended above the Newton tolerance
  long newton_automatic_steps = 0;  ///< backward Euler steps taken again with Newton iterations (kBackwardEulerNewton)
  double newton_seconds = 0;     ///< the iterations' own work: residuals, assemblies, solves
};

}  // namespace weft
