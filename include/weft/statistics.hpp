#pragma once
// Statistics a run reports (summary.json): the steps and their solves (each declared once, in
// WEFT_STEP_STATISTICS), and the stiffness factors and added viscosity of adaptive damping.
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

/// Every statistic of the steps (StepStatistics) once:
/// X(kind, field, group, key, meaning). `kind` is kCount (a long), kLargest or kSeconds (a
/// double); summary.json reports the field under `key` in its object `group` ("": the top
/// level; "contacts", "guard" and "newton" where the run has them), and "" as key for one it
/// reports only through a derived value (a mean, a fraction). A checkpoint holds the counts,
/// then the largest values, then the seconds, each kind in this order; the Python module's
/// Simulation.statistics() names each by its field. A new statistic is a line here.
#define WEFT_STEP_STATISTICS(X)                                                                                      \
  X(kCount, steps, "", "steps", "accepted steps")                                                                    \
  X(kCount, rejected_steps, "", "rejected_steps", "RK45 rejections")                                                \
  X(kCount, cg_iterations, "", "solver_iterations_total", "conjugate-gradient iterations")                          \
  X(kCount, cg_solves, "", "", "linear solves")                                                                     \
  X(kCount, cg_failures, "", "solver_failures", "solves that hit the iteration cap")                                \
  X(kSeconds, assembly_seconds, "", "assembly_seconds", "assembling forces and step matrices")                      \
  X(kSeconds, solve_seconds, "", "solve_seconds",                                                                   \
    "the linear solves and their warm start (not the contacts within)")                                             \
  X(kCount, contacts, "contacts", "", "node contacts held by linear steps (whole steps or their parts), summed")     \
  X(kCount, contact_solves, "contacts", "", "linear steps (whole steps or their parts) that held contacts")          \
  X(kCount, max_contacts, "contacts", "node_contacts_max",                                                          \
    "the most in one linear step (never below contacts / contact_solves)")                                          \
  X(kCount, released_contacts, "contacts", "released", "contacts let go because they pulled at the previous step")  \
  X(kCount, fail_safe_moves, "contacts", "fail_safe_moves", "nodes moved by the contact fail-safe after a step")     \
  X(kCount, contact_passes, "contacts", "repeated_solves",                                                          \
    "solves repeated because nodes would have ended in a collider")                                                 \
  X(kCount, failed_contact_steps, "contacts", "failed_steps", "steps the contact fail-safe could not make valid")     \
  X(kCount, halved_steps, "contacts", "halved_steps", "steps taken again as two halves for that reason")             \
  X(kSeconds, detection_seconds, "contacts", "detection_seconds", "finding contacts")                               \
  X(kSeconds, response_seconds, "contacts", "response_seconds", "constraints, friction and the fail-safe")          \
  X(kCount, guard_redone_steps, "guard", "redone_steps", "attempts the energy guard took again with a larger alpha") \
  X(kCount, guard_raised_steps, "guard", "raised_steps",                                                            \
    "accepted steps taken (in part) with an alpha above the scene's")                                               \
  X(kLargest, guard_max_alpha, "guard", "", "the largest alpha of an accepted guarded step (0: none)")               \
  X(kCount, guard_split_steps, "guard", "split_steps", "guarded steps (or parts) taken again as two halves")          \
  X(kCount, guard_futile_splits, "guard", "futile_splits",                                                          \
    "halvings given up because the first half put in as much")                                                      \
  X(kCount, guard_parts, "guard", "", "parts the guarded steps were taken in, halvings included")                    \
  X(kCount, guard_newton_steps, "guard", "newton_last_resorts",                                                     \
    "last resorts taken again with Newton iterations (kGuardLastResortNewton)")                                     \
  X(kSeconds, guard_seconds, "guard", "seconds", "the guard's own work: saving the start, the energy check")         \
  X(kCount, newton_iterations, "newton", "iterations",                                                              \
    "Newton iterations (one linear solve each) beyond the linearised step")                                         \
  X(kCount, newton_steps, "newton", "iterated_steps", "steps (or parts) that took at least one")                    \
  X(kCount, newton_halvings, "newton", "line_search_halvings", "line-search halvings")                               \
  X(kCount, newton_unconverged, "newton", "unconverged_steps", "steps that ended above the Newton tolerance")         \
  X(kCount, newton_automatic_steps, "newton", "automatic_steps",                                                    \
    "backward Euler steps taken again with Newton iterations (kBackwardEulerNewton)")                               \
  X(kSeconds, newton_seconds, "newton", "seconds", "the iterations' own work: residuals, assemblies, solves")

/// The kinds of WEFT_STEP_STATISTICS.
enum class StatisticKind { kCount, kLargest, kSeconds };
#define WEFT_STATISTIC_TYPE_kCount long
#define WEFT_STATISTIC_TYPE_kLargest double
#define WEFT_STATISTIC_TYPE_kSeconds double

struct StepStatistics {
#define WEFT_STATISTIC_FIELD(kind, field, group, key, meaning) WEFT_STATISTIC_TYPE_##kind field = 0;
  WEFT_STEP_STATISTICS(WEFT_STATISTIC_FIELD)
#undef WEFT_STATISTIC_FIELD
};

/// One line of WEFT_STEP_STATISTICS, for code that visits every statistic (the checkpoint,
/// summary.json, the Python module).
struct StepStatistic {
  StatisticKind kind;
  const char* field;
  const char* group;                ///< summary.json's object ("": the top level)
  const char* key;                  ///< the key there ("": reported only through a derived value)
  const char* meaning;
  long StepStatistics::*count;      ///< the field of a kCount (else null)
  double StepStatistics::*value;    ///< the field of a kLargest or kSeconds (else null)
  /// Its value in st, as a double.
  double of(const StepStatistics& st) const { return count ? static_cast<double>(st.*count) : st.*value; }
};

namespace statistics_detail {
constexpr StepStatistic entry(StatisticKind kind, const char* field, const char* group, const char* key,
                              const char* meaning, long StepStatistics::*count) {
  return {kind, field, group, key, meaning, count, nullptr};
}
constexpr StepStatistic entry(StatisticKind kind, const char* field, const char* group, const char* key,
                              const char* meaning, double StepStatistics::*value) {
  return {kind, field, group, key, meaning, nullptr, value};
}
}  // namespace statistics_detail

/// Every statistic of WEFT_STEP_STATISTICS, in its order.
inline constexpr StepStatistic kStepStatistics[] = {
#define WEFT_STATISTIC_ENTRY(kind, field, group, key, meaning) \
  statistics_detail::entry(StatisticKind::kind, #field, group, key, meaning, &StepStatistics::field),
    WEFT_STEP_STATISTICS(WEFT_STATISTIC_ENTRY)
#undef WEFT_STATISTIC_ENTRY
};

}  // namespace weft
