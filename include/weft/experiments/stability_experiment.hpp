#pragma once
// The stability experiment (paper figure 5): a free square of cloth, no gravity and no pins,
// starts from a large seeded random deformation and is simulated with each integrator, time
// step and adaptive damping ratio. Each cell records whether the run stayed stable (and why
// not: non-finite state, energy growth, linear-solver failure) and when the cloth came to rest.
// Without gravity and pins only internal forces act, so the cell isolates the integrator's
// treatment of the cloth's own stiffness (docs/method.md 3-4).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "weft/scene.hpp"
#include "weft/types.hpp"

namespace weft {

/// One integrator of the experiment: a method name of method_table() and its alpha.
struct StabilityMethod {
  std::string label;            ///< shown in tables, e.g. "alpha 2/3"
  std::string name;             ///< method_table() name
  std::optional<double> alpha;  ///< only for methods that take one
};

/// The default list: forward Euler, backward Euler, Implicit Midpoint, alpha 0.6, alpha 2/3,
/// BDF-2 and BDF-2 with alpha 1/sqrt(3).
std::vector<StabilityMethod> default_stability_methods();
/// Parses a comma-separated list of NAME or NAME:ALPHA (ALPHA a number or p/q), e.g.
/// "implicit-midpoint,alpha:2/3,bdf2-alpha". Throws InputError naming `option` and the value.
std::vector<StabilityMethod> parse_stability_methods(const std::string& list, const std::string& option);

struct StabilityExperimentSettings {
  double size_m = 0.5;                  ///< side of the square
  int resolution = 11;                  ///< vertices per side
  double duration_s = 3.0;
  std::uint64_t seed = 1;
  // Linear material: stretch (weft and warp) and shear moduli, density, bending, no viscosity of
  // its own, so all damping comes from the adaptive ratio under test.
  double stretch_modulus_N_m = 500.0;
  double shear_modulus_N_m = 50.0;
  double surface_density_kg_m2 = 0.15;
  double bending_rigidity_Nm = 1e-5;
  // Perturbation (METHOD-independent, same for every cell): a smooth random fold field of
  // amplitude fold_fraction * size, a per-vertex jitter up to jitter_fraction * edge length in
  // each coordinate, and a smooth random velocity field of amplitude velocity_m_s, from which
  // the rigid-body (linear and angular momentum) part is removed.
  double fold_fraction = 0.1;
  double jitter_fraction = 0.05;
  double velocity_m_s = 0.5;
  /// At rest: kinetic energy below rest_fraction times the initial energy at every step of a
  /// window of rest_window_s (the run stops there; the rest time is the window's start).
  double rest_fraction = 1e-4;
  double rest_window_s = 0.1;
  double cg_tolerance = 1e-6;
  std::vector<StabilityMethod> methods = default_stability_methods();
  std::vector<double> dts = {0.001, 0.002, 0.005, 0.01, 0.02, 0.05};
  std::vector<double> ratios = {0.0, 0.01, 0.02, 0.05, 0.10};
};

/// Throws InputError naming the option (by its command-line name) and value.
void validate(const StabilityExperimentSettings& s);

/// The scene of one cell: the square in the xy plane, no gravity, no pins, linear material.
Scene stability_scene(const StabilityExperimentSettings& s, const StabilityMethod& method, double dt,
                      double damping_ratio);

/// The perturbed start (3n positions and velocities) for a mesh with the given rest positions:
/// a function of the settings and the seed only.
void stability_perturbation(const StabilityExperimentSettings& s, const TriMesh& mesh, const VecX& mass, VecX& x,
                            VecX& v);

struct StabilityCell {
  std::string method;          ///< label
  double alpha = 0;
  double dt = 0;
  double damping_ratio = 0;
  bool stable = true;
  std::string reason;          ///< "" when stable; "nan", "energy" or "cg"
  double unstable_time = -1;   ///< s, when it became unstable
  double rest_time = -1;       ///< s, when it came to rest; -1 when not within the duration
  double kappa_max = 0;        ///< largest membrane kappa at the start
  double max_energy_ratio = 0; ///< largest (kinetic + elastic) / initial over the run
  double final_energy_ratio = 0;
  double final_kinetic_ratio = 0; ///< kinetic / initial (kinetic + elastic) at the last step
  long steps = 0;
  double cg_iterations_mean = 0;
  double wall_seconds = 0;
};

/// Runs one cell.
StabilityCell run_stability_cell(const StabilityExperimentSettings& s, const StabilityMethod& method, double dt,
                                 double damping_ratio);

struct StabilityExperimentResult {
  StabilityExperimentSettings settings;
  std::vector<StabilityCell> cells;  ///< method-major, then dt, then ratio
  double initial_energy = 0;         ///< J, kinetic + elastic of the perturbed start
  double wall_seconds = 0;
};

/// Runs every cell; `progress` (optional) gets the fraction done after each cell.
StabilityExperimentResult run_stability_experiment(const StabilityExperimentSettings& s,
                                                   const std::function<void(double)>& progress = {});

/// CSV: one row per cell, header first.
std::string stability_csv(const StabilityExperimentResult& r);
/// Markdown: the settings, then one table per method (rows dt, columns damping ratio; a cell
/// shows the rest time, "moving" when stable but not at rest, or "unstable (reason, time)").
std::string stability_markdown(const StabilityExperimentResult& r);

}  // namespace weft
