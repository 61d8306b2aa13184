#pragma once
// Running a scene: the library entry point behind `weft run`, the experiments and the
// benchmarks. The core never touches files; writing frames is the caller's callback.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "system/cloth.hpp"
#include "weft/scene.hpp"

namespace weft {

/// Energies at one output frame (METHOD.md 6), in joules.
struct EnergyRow {
  double time = 0;
  double kinetic = 0;
  double elastic = 0;
  double gravity = 0;             ///< gravitational potential relative to the initial state
  double viscous_dissipated = 0;  ///< cumulative work against viscous forces
  double numerical_dissipated = 0;///< initial total minus the four above
  double total() const { return kinetic + elastic + gravity; }
};

/// Everything needed to step a scene: the model, the system and the integrator.
class Simulation {
 public:
  explicit Simulation(const Scene& scene);
  const Scene& scene() const { return scene_; }
  const ClothModel& model() const { return *model_; }
  ClothSystem& system() { return *system_; }
  const ClothSystem& system() const { return *system_; }
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  State& state() { return state_; }
  const State& state() const { return state_; }
  const StepStatistics& statistics() const { return stats_; }
  /// Replaces positions and velocities (e.g. a perturbed start) and makes it the reference of
  /// the energy accounting: time 0, no dissipation yet, no BDF-2 history.
  void reset_state(const VecX& x, const VecX& v);
  /// Advances to time t (s).
  void advance_to(double t) { integrator_->advance(state_, t, stats_); }
  /// Energies at the current state.
  EnergyRow energies();
  /// A scale of the scene's energy (J): initial kinetic + elastic + weight times size.
  double energy_scale() const { return energy_scale_; }

 private:
  Scene scene_;
  std::unique_ptr<ClothModel> model_;
  std::unique_ptr<ClothSystem> system_;
  std::unique_ptr<Integrator> integrator_;
  State state_;
  StepStatistics stats_;
  Evaluation eval_;
  double gravity0_ = 0, total0_ = 0, energy_scale_ = 0;
  void set_energy_reference();
};

struct RunResult {
  std::string status = "ok";        ///< "ok" or "unstable"
  std::string message;              ///< why it became unstable
  double unstable_time = 0;
  std::vector<EnergyRow> energy;    ///< one row per output frame
  StepStatistics steps;
  DampingStatistics damping;
  double wall_seconds = 0;
  double damping_ratio = 0;
  long vertices = 0, triangles = 0;
};

struct RunCallbacks {
  /// Called for every output frame (first at time 0) with its index and state.
  std::function<void(int frame, const Simulation& sim)> on_frame;
  /// Called after every frame with the fraction done.
  std::function<void(double fraction)> on_progress;
};

/// Runs the scene to its duration, stopping early when it becomes unstable (a non-finite
/// value, or mechanical energy rising above its initial value by more than the scene's
/// energy scale: with static pins nothing can add energy).
RunResult run_simulation(Simulation& sim, const RunCallbacks& callbacks = {});

/// The summary as JSON (the fields of summary.json).
nlohmann::json summary_json(const Simulation& sim, const RunResult& result);
/// energy.csv text: header row then one row per frame.
std::string energy_csv(const std::vector<EnergyRow>& rows);

}  // namespace weft
