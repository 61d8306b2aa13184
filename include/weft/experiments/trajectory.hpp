#pragma once
// One scene run with a chosen integrator and damping, keeping every output frame's positions:
// the building block of the accuracy, energy and convergence experiments.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "weft/atomic_file.hpp"
#include "weft/scene.hpp"
#include "weft/simulation.hpp"

namespace weft {

/// An integrator with its damping, as the experiments name it.
struct MethodConfiguration {
  std::string label;            ///< unique, file-name safe, e.g. "implicit-midpoint-damped"
  std::string method;           ///< a name from method_table()
  std::optional<double> alpha;  ///< for "alpha" and "bdf2-alpha"
  double damping_ratio = 0.0;   ///< adaptive damping target (fraction of critical)
};

struct Trajectory {
  MethodConfiguration configuration;
  Scene scene;                  ///< the scene as run (method, dt, damping set)
  RunResult result;             ///< energies per frame, step statistics, status
  nlohmann::json summary;       ///< summary_json of the run
  std::vector<VecX> positions;  ///< 3n positions per output frame, until it became unstable
};

/// Overrides `scene`'s integrator, step, damping and (for rk45) error tolerance and CG
/// tolerance (when > 0) with the configuration's; validates. Throws InputError.
Scene configure_scene(const Scene& scene, const MethodConfiguration& configuration, double dt,
                      double rk45_tolerance, double cg_tolerance = 0.0);

/// Runs a configured scene to its duration, keeping positions when `keep_positions`.
/// An unstable run ends early with result.status "unstable" (never throws for it).
Trajectory run_trajectory(const Scene& configured, const MethodConfiguration& configuration,
                          bool keep_positions, const std::function<void(double)>& progress = {});

/// Root mean square over vertices of the distance between two 3n position vectors (m).
double rms_distance(const VecX& a, const VecX& b);

/// rms_distance at every frame both sequences have.
std::vector<double> rms_distance_per_frame(const std::vector<VecX>& a,
                                           const std::vector<VecX>& reference);

/// Root mean square of per-frame values (over the whole run); 0 for none.
double root_mean_square(const std::vector<double>& values);

/// Median of the values (mean of the middle two for an even count); NaN for none.
double median(std::vector<double> values);

/// A text file for write_files_atomically.
PendingFile pending_text_file(const std::filesystem::path& path, std::string content);

/// Throws InputError "OPTION VALUE: expected a positive finite number" unless it is one.
void require_positive_finite(const std::string& option, double value);
/// Throws InputError unless 0 <= value <= 10 (a damping ratio, fraction of critical).
void require_damping_ratio(const std::string& option, double value);

/// A number for CSV and messages: %.10g.
std::string format_number(double value);

}  // namespace weft
