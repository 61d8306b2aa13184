#pragma once
// The paper's energy and accuracy comparison (docs/method.md 7, figures 8-10): one scene run with
// backward Euler undamped, Implicit Midpoint damped, BDF-2 undamped, BDF-2 alpha = 1/sqrt(3)
// damped, all at the same dt, and adaptive RK45 damped and undamped as references. Motion
// accuracy is the RMS vertex distance from the RK45 run with the same damping; speed is
// Implicit Midpoint against backward Euler in interleaved repeats.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "weft/experiments/energy_injection.hpp"
#include "weft/experiments/trajectory.hpp"

namespace weft {

struct EnergyExperimentOptions {
  double dt = 0.02;              ///< step of the fixed-step methods and RK45's largest step (s)
  double damping_ratio = 0.05;   ///< of the damped configurations
  double rk45_tolerance = 1e-6;  ///< local error tolerance of the references
  int speed_repeats = 5;         ///< interleaved Implicit Midpoint / backward Euler pairs
  /// Newton iterations of the semi-implicit configurations (IntegratorSettings::
  /// newton_iterations); unset: the scene's.
  std::optional<int> newton_iterations;
  /// Splits the energy Implicit Midpoint (damped) creates among the triangles
  /// (analyse_energy_injection): one more run of that configuration.
  bool injection = true;
};

/// Energy the integrator created (J): the falls of the numerical dissipation from one output
/// frame to the next (docs/method.md 6: the numerical dissipation is what is left of the initial
/// energy and the contacts' work after the mechanical energies and the viscous work, so a fall
/// is energy no force put in).
struct EnergyCreated {
  double largest = 0;          ///< the largest fall over one frame interval
  double time_of_largest = 0;  ///< the end of that interval (s)
  double total = 0;            ///< the sum of the falls over the run
  long frames = 0;             ///< frame intervals with a fall
};
EnergyCreated energy_created(const std::vector<EnergyRow>& rows);

/// The six configurations, in plotting order; `reference` names the RK45 run each is compared to.
struct EnergyConfiguration {
  MethodConfiguration configuration;
  std::string reference;  ///< label of the RK45 run with the same damping ("" for the references)
};
std::vector<EnergyConfiguration> energy_configurations(double damping_ratio);

/// Wall time and CG iterations per step of Implicit Midpoint (damped) and backward Euler
/// (undamped) at the same dt, run alternately (which goes first alternates too).
struct SpeedComparison {
  int repeats = 0;
  std::vector<double> midpoint_seconds, backward_euler_seconds;
  std::vector<double> midpoint_cg_per_step, backward_euler_cg_per_step;
  long midpoint_steps = 0, backward_euler_steps = 0;
  int unstable_runs = 0;      ///< runs that stopped early: their times do not compare like for like
  double wall_ratio() const;  ///< median(midpoint) / median(backward Euler)
  double cg_ratio() const;    ///< same for CG iterations per step
};

struct EnergyRunResult {
  EnergyConfiguration entry;
  Trajectory trajectory;
  std::vector<double> rms_per_frame;  ///< against the reference (empty for the references)
};

struct EnergyExperiment {
  Scene scene;
  EnergyExperimentOptions options;
  std::vector<EnergyRunResult> runs;
  SpeedComparison speed;
  std::optional<InjectionAnalysis> injection;  ///< EnergyExperimentOptions::injection
};

using ExperimentProgress = std::function<void(const std::string& label, double fraction)>;

/// Runs every configuration (and the speed repeats). Throws InputError for bad options.
EnergyExperiment run_energy_experiment(const Scene& scene, const EnergyExperimentOptions& options,
                                       const ExperimentProgress& progress = {});

/// Writes DIR/LABEL/{energy.csv,summary.json}, DIR/results.{json,csv}, DIR/rms.csv,
/// DIR/speed.csv and the figures DIR/energy.{gp,png,svg}, DIR/rms.{gp,png,svg}; with the
/// injection analysis DIR/injection/ (write_energy_injection).
/// Returns warnings (e.g. gnuplot missing); throws on a write failure.
std::vector<std::string> write_energy_experiment(const EnergyExperiment& experiment,
                                                 const std::filesystem::path& dir);

/// The content of results.json.
nlohmann::json energy_results_json(const EnergyExperiment& experiment);

/// CPU model name (from /proc/cpuinfo) and logical core count, for recording where numbers ran.
nlohmann::json machine_json();

/// The fields every experiment's JSON starts with: experiment name, weft version, scene file
/// and machine.
nlohmann::json experiment_json(const std::string& name, const Scene& scene);

}  // namespace weft
