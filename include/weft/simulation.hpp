#pragma once
// Running a scene: the library entry point behind `weft run`, the experiments and the
// benchmarks. The core never touches files; writing frames is the caller's callback.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "weft/collider.hpp"
#include "weft/mesh.hpp"
#include "weft/scene.hpp"
#include "weft/statistics.hpp"
#include "weft/types.hpp"

namespace weft {

class SimulationCore;
struct SimulationModel;

/// Called while a Simulation is built: the stage starting ("cloth mesh", "model", ...) and the
/// fraction of the set-up done before it (1 with stage "done" at the end).
using SetupProgress = std::function<void(const std::string& stage, double fraction)>;

/// Energies at one output frame (docs/method.md 6), in joules.
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

/// What a scene defines and no step changes: the cloth's mesh (a garment meshed, placed and
/// sewn), its elements, masses and pins, the integrator's settings and what follows from them,
/// the walking bodies and the collider meshes. A Simulation built from a Scene builds its own;
/// Simulations made from one shared Model are independent simulations of the same scene that
/// pay for the set-up once (docs/api.md, "Model and data"). No step changes a Model, so
/// Simulations sharing one may be stepped on different threads.
class Model {
 public:
  /// Builds what Simulation(scene) builds; throws InputError as it does.
  explicit Model(const Scene& scene, const SetupProgress& on_setup = {});
  ~Model();
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  const Scene& scene() const;
  /// The cloth mesh as built (Simulation::mesh).
  const TriMesh& mesh() const;
  int vertex_count() const;
  /// Simulation::fingerprint: the same for every Simulation of this model.
  std::uint64_t fingerprint() const;
  /// The parts, for weft's own code: SimulationModel is defined in the library's private
  /// headers (src/sim/model_data.hpp) and is not part of the API.
  const SimulationModel& core() const { return *impl_; }

 private:
  std::unique_ptr<SimulationModel> impl_;
};

/// A scene being simulated: built from a Scene (or a shared Model), advanced in time, its state and statistics
/// read, its pins and colliders moved between steps. What `weft run`, the experiments, the
/// benchmarks and the Python module drive.
class Simulation {
 public:
  /// Called while the constructor works (SetupProgress).
  using SetupProgress = weft::SetupProgress;
  /// Builds the cloth, its model and the colliders; throws InputError naming the scene's key
  /// for what the scene's validation could not see (a pin out of range, a pattern that does
  /// not mesh, a run too large for the machine).
  explicit Simulation(const Scene& scene, const SetupProgress& on_setup = {});
  /// A simulation of a shared model at the scene's start, with its own state, statistics,
  /// contacts and solver history: what it does, the model's other Simulations never see.
  /// Throws InputError for a null model.
  explicit Simulation(std::shared_ptr<const Model> model);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const Scene& scene() const;
  /// The model this simulation steps, to make more Simulations of it.
  const std::shared_ptr<const Model>& model() const;
  double time() const;  ///< simulated time (s)
  /// The cloth mesh as the simulation built it: its starting positions, pattern coordinates
  /// and triangles (a garment's sewn mesh, a grid, an OBJ).
  const TriMesh& mesh() const;
  int vertex_count() const;
  /// Positions (m) and velocities (m/s), 3 per vertex. Their storage stays the same from step
  /// to step; what is written into them between steps is where the next step starts from (the
  /// energy reference and a BDF-2 history stay as they were: reset_state starts afresh).
  const VecX& positions() const;
  const VecX& velocities() const;
  VecX& positions();
  VecX& velocities();
  const VecX& masses() const;  ///< one per vertex (kg)
  /// Per vertex: 1 where the scene pins it, 0 elsewhere (clamped vertices move with their clamps).
  const std::vector<char>& pinned() const;
  /// The viscosity adaptive damping added at the last step, per vertex (N s/m; the area-weighted
  /// mean over the vertex's triangles of its largest mode's addition).
  VecX added_viscosity_per_vertex() const;
  const StepStatistics& step_statistics() const;
  const DampingStatistics& damping_statistics() const;
  size_t collider_count() const;
  /// Collider k's description (the scene's, colliders in file order).
  const ColliderSpec& collider(size_t k) const;
  /// Collider k's surface at time t: a walking body's skinned mesh, another collider's surface
  /// (what the frames' body<k> and collider<k> files hold).
  void collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const;

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
  size_t moving_pins() const;
  /// Replaces the motion of collider k from now on: from its pose now to `target` at time
  /// `arrival` (rounded like move_pins'), linearly (the rotation by spherical interpolation),
  /// then held there. A pose is the transform the collider's motion applies to the collider as
  /// the scene places it (the identity at t = 0 for a static or constant-velocity motion).
  /// Throws InputError for a walking body (its motion comes from its motion file), an index
  /// out of range or an arrival not after now.
  void move_collider(size_t k, const Eigen::Isometry3d& target, double arrival);
  /// The pose of collider k at time t (move_collider).
  Eigen::Isometry3d collider_pose(size_t k, double t) const;
  /// Energies at the current state.
  EnergyRow energies();
  /// A scale of the scene's energy (J): initial kinetic + elastic + weight times size, or the
  /// kinetic energy the cloth would have moving as fast as its fastest moving collider or
  /// clamp (its largest displacement over 0.1 s, sampled over the duration at set-up),
  /// whichever is larger.
  double energy_scale() const;
  /// Mechanical energy (kinetic + elastic + gravity) of the reference state (J).
  double initial_total_energy() const;
  /// A hash of what a step's result depends on in the model and settings: the mesh's
  /// positions, masses, pins and pattern, its elements, materials (curves and coupling
  /// included), the integrator settings, the damping, the clamps, colliders and bodies.
  std::uint64_t fingerprint() const;

  /// The parts behind this simulation, for weft's own code: SimulationCore is defined in the
  /// library's private headers (src/sim/simulation_core.hpp) and is not part of the API.
  SimulationCore& core() { return *core_; }
  const SimulationCore& core() const { return *core_; }

 private:
  std::unique_ptr<SimulationCore> core_;
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

/// 64-bit FNV-1a of `size` bytes, continuing from `hash`: the checksum of checkpoints, and the
/// hash `weft run` keeps of the scene a checkpoint was made from.
std::uint64_t fnv1a(const void* data, size_t size, std::uint64_t hash = 0xcbf29ce484222325ull);

/// A checkpoint (docs/run-outputs.md, "Checkpoints and resuming") of a run at a frame
/// boundary: `header` (what the caller needs to rebuild the Simulation), sim's state and the
/// run so far. The bytes to write to a file.
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
