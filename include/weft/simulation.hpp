#pragma once
// Running a scene: the library entry point behind `weft run`, the experiments and the
// benchmarks. The core never touches files; writing frames is the caller's callback.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "system/cloth.hpp"
#include "weft/scene.hpp"

namespace weft {

class BinaryWriter;
class BinaryReader;
class Collider;
class ColliderContacts;
class SelfContacts;
class Clamps;

/// Energies at one output frame (METHOD.md 6), in joules.
struct EnergyRow {
  double time = 0;
  double kinetic = 0;
  double elastic = 0;
  double gravity = 0;             ///< gravitational potential relative to the initial state
  double viscous_dissipated = 0;  ///< cumulative work against viscous forces
  double numerical_dissipated = 0;///< initial total plus contact work minus the four above
  double contact_work = 0;        ///< cumulative work of contact and friction forces on the cloth
  double fail_safe_work = 0;      ///< the part of contact_work done by the fail-safes' corrections
  /// Guarded methods (docs/guarded-midpoint.md), 0 otherwise: the parts the guarded steps were
  /// taken in since the start (the steps, where the guard never split one), and the alpha the
  /// guard's next step starts at (the method's own where it is calm).
  double guard_parts = 0;
  double guard_alpha = 0;
  double total() const { return kinetic + elastic + gravity; }
};

/// Everything needed to step a scene: the model, the system and the integrator.
class Simulation {
 public:
  /// Called while the constructor works: the stage starting ("cloth mesh", "model", ...) and
  /// the fraction of the set-up done before it (1 with stage "done" at the end).
  using SetupProgress = std::function<void(const std::string& stage, double fraction)>;
  explicit Simulation(const Scene& scene, const SetupProgress& on_setup = {});
  ~Simulation();
  const Scene& scene() const { return scene_; }
  const ClothModel& model() const { return *model_; }
  ClothSystem& system() { return *system_; }
  const ClothSystem& system() const { return *system_; }
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  State& state() { return state_; }
  const State& state() const { return state_; }
  const StepStatistics& statistics() const { return stats_; }
  /// The scene's colliders in file order (Collider::surface draws one at any time).
  const std::vector<std::unique_ptr<Collider>>& colliders() const { return colliders_; }
  /// The walking bodies of the body colliders (Scene::bodies order).
  const std::vector<std::unique_ptr<WalkingBody>>& bodies() const { return bodies_; }
  /// Collider k's surface at time t: a walking body's skinned mesh, another collider's as
  /// Collider::surface draws it (what the frames' body<k> and collider<k> files hold).
  void collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const;
  /// Cloth-cloth contact handling; null when the scene turns self_collision off.
  const SelfContacts* self_contacts() const { return self_contacts_.get(); }
  /// Replaces positions and velocities (e.g. a perturbed start) and makes it the reference of
  /// the energy accounting: time 0, no dissipation yet, no BDF-2 history.
  void reset_state(const VecX& x, const VecX& v);
  /// Advances to time t (s), stopping pins on their targets when they arrive (move_pins).
  void advance_to(double t);

  /// Moves pinned vertices in straight lines at constant velocities from where they are to
  /// `targets` (one per vertex of `nodes`), arriving at time `arrival` (s, after now; for a
  /// fixed-step method rounded to a whole number of steps, one at least), where they stop. The
  /// solve sees the pins' velocities, so the cloth is pulled along smoothly. Their work on the
  /// cloth is not booked: it shows in EnergyRow::numerical_dissipated. A vertex moved again
  /// before it arrived starts its new move from where it is. Throws InputError naming the
  /// vertex that is not pinned, and for an arrival not after now or a non-finite target.
  void move_pins(const std::vector<int>& nodes, const std::vector<Vec3>& targets, double arrival);
  /// The pins still moving to their targets (move_pins).
  size_t moving_pins() const { return pin_moves_.size(); }
  /// Replaces the motion of collider k (colliders() order) for the steps from now on: from its
  /// pose now to `target` at time `arrival` (rounded like move_pins'), linearly (the rotation
  /// by spherical interpolation), then held there. A pose is the transform the collider's
  /// motion applies to the collider as the scene places it (the identity at t = 0 for a
  /// scene's static or constant-velocity motion). Throws InputError for a walking body (its
  /// motion comes from its motion file), an index out of range or an arrival not after now.
  void move_collider(size_t k, const Eigen::Isometry3d& target, double arrival);
  /// The pose of collider k at time t (move_collider).
  Eigen::Isometry3d collider_pose(size_t k, double t) const;
  /// Energies at the current state.
  EnergyRow energies();
  /// A scale of the scene's energy (J): initial kinetic + elastic + weight times size.
  double energy_scale() const { return energy_scale_; }
  /// Mechanical energy (kinetic + elastic + gravity) of the reference state (J).
  double initial_total_energy() const { return total0_; }

  /// Writes everything later steps and the run's statistics depend on, bit for bit: the
  /// State, the step statistics, the energy reference and the system's and integrator's
  /// dynamic state, after a fingerprint of the model and settings.
  void save(BinaryWriter& out) const;
  /// Reads what save wrote into a Simulation built from the same scene and settings; throws
  /// InputError (through `in`) when the fingerprint or a size does not match.
  void restore(BinaryReader& in);
  /// A hash of what a step's result depends on in the model and settings: the mesh's
  /// positions, masses, pins and pattern, the integrator settings and the damping.
  std::uint64_t fingerprint() const;

 private:
  Scene scene_;
  std::unique_ptr<ClothModel> model_;
  std::unique_ptr<ClothSystem> system_;
  std::unique_ptr<Integrator> integrator_;
  std::vector<std::unique_ptr<WalkingBody>> bodies_;
  std::vector<std::unique_ptr<Collider>> colliders_;
  std::unique_ptr<ColliderContacts> contacts_;
  std::unique_ptr<SelfContacts> self_contacts_;
  std::unique_ptr<Clamps> clamps_;
  State state_;
  StepStatistics stats_;
  Evaluation eval_;
  double gravity0_ = 0, total0_ = 0, energy_scale_ = 0;
  struct PinMove {
    int node;
    Vec3 target;
    double arrival;
  };
  std::vector<PinMove> pin_moves_;  ///< move_pins: the pins on their way
  void set_energy_reference();
  /// Sets the velocity of pinned vertex i (and its BDF-2 history, as if it had moved so before).
  void set_pin_velocity(int i, const Vec3& v);
  /// `arrival` on the step grid from now (fixed-step methods); checks it is after now.
  double arrival_time(double arrival, const std::string& what) const;
};

struct RunResult {
  /// "ok", "unstable", or "interrupted" (RunCallbacks::after_frame asked to stop).
  std::string status = "ok";
  std::string message;              ///< why it became unstable
  double unstable_time = 0;
  std::vector<EnergyRow> energy;    ///< one row per output frame
  StepStatistics steps;
  DampingStatistics damping;
  double wall_seconds = 0;          ///< including the wall time before a checkpoint
  double damping_ratio = 0;
  long vertices = 0, triangles = 0;
};

struct RunCallbacks {
  /// Called for every output frame (first at time 0) with its index and state.
  std::function<void(int frame, const Simulation& sim)> on_frame;
  /// Called after every frame with the fraction done.
  std::function<void(double fraction)> on_progress;
  /// Called at every frame boundary after on_frame, with the result so far (the energy rows
  /// and wall time); returning true stops the run there with status "interrupted".
  std::function<bool(const RunResult& so_far)> after_frame;
};

/// Runs the scene to its duration, stopping early when it becomes unstable (a non-finite
/// value, or mechanical energy rising above its initial value by more than the scene's
/// energy scale: with static pins nothing can add energy).
/// `resumed`: the result so far of the run `sim` was restored from (read_checkpoint); the
/// run goes on from the frame after its last.
RunResult run_simulation(Simulation& sim, const RunCallbacks& callbacks = {}, const RunResult* resumed = nullptr);

/// A checkpoint (sim/checkpoint.hpp) of a run at a frame boundary: `header` (what the
/// caller needs to rebuild the Simulation), sim's state and the run so far. The bytes to
/// write to a file.
std::string checkpoint_bytes(const nlohmann::json& header, const Simulation& sim, const RunResult& so_far);
/// The header of the checkpoint in `bytes` read from `file`; throws InputError naming the
/// file for anything other than an undamaged checkpoint of this format version.
nlohmann::json checkpoint_header(const std::string& bytes, const std::string& file);
/// Restores sim (built from what the header describes) from the checkpoint and returns the
/// run so far; throws InputError naming the file when it does not fit the simulation.
RunResult restore_checkpoint(const std::string& bytes, const std::string& file, Simulation& sim);

/// The summary as JSON (the fields of summary.json). Its status is the result's, except
/// "solver_capped" for a run otherwise ok in which a linear solve stopped at the iteration
/// cap before reaching the tolerance.
nlohmann::json summary_json(const Simulation& sim, const RunResult& result);
/// energy.csv text: header row then one row per frame.
std::string energy_csv(const std::vector<EnergyRow>& rows);

}  // namespace weft
