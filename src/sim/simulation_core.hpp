#pragma once
// The simulation behind weft::Simulation, with its parts in reach (not part of the public API).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/model_data.hpp"

namespace weft {

/// What the public Simulation (weft/simulation.hpp) steps: a SimulationModel and one
/// SimulationData of it (sim/model_data.hpp), with a ClothSystem and an Integrator that view
/// them. weft's own code (the experiments, the tests of the parts) reaches it through
/// Simulation::core().
class SimulationCore {
 public:
  explicit SimulationCore(const Scene& scene, const SetupProgress& on_setup = {});
  /// A simulation of a shared model, at the scene's start.
  explicit SimulationCore(std::shared_ptr<const Model> model);
  ~SimulationCore();
  const std::shared_ptr<const Model>& shared_model() const { return model_; }
  const SimulationModel& simulation_model() const { return *m_; }
  SimulationData& simulation_data() { return *data_; }
  const SimulationData& simulation_data() const { return *data_; }
  const Scene& scene() const { return m_->scene; }
  const ClothModel& model() const { return *m_->cloth; }
  ClothSystem& system() { return *system_; }
  const ClothSystem& system() const { return *system_; }
  Integrator& integrator() { return *integrator_; }
  const Integrator& integrator() const { return *integrator_; }
  State& state() { return data_->state; }
  const State& state() const { return data_->state; }
  const StepStatistics& statistics() const { return data_->statistics; }
  /// The scene's colliders in file order (Collider::surface draws one at any time).
  const std::vector<std::unique_ptr<Collider>>& colliders() const { return data_->colliders; }
  /// The walking bodies of the body colliders (Scene::bodies order).
  const std::vector<std::unique_ptr<WalkingBody>>& bodies() const { return m_->bodies; }
  /// Collider k's surface at time t: a walking body's skinned mesh, another collider's as
  /// Collider::surface draws it (what the frames' body<k> and collider<k> files hold).
  void collider_surface(size_t k, double t, Points& positions, Triangles& triangles) const;
  /// Cloth-cloth contact handling; null when the scene turns self_collision off.
  const SelfContacts* self_contacts() const { return data_->self_contacts.get(); }
  /// Replaces positions and velocities (e.g. a perturbed start) and makes it the reference of
  /// the energy accounting: time 0, no dissipation yet, no BDF-2 history.
  void reset_state(const VecX& x, const VecX& v);
  /// Advances to time t (s), stopping pins on their targets when they arrive (move_pins).
  /// With `stop_on_runaway`, stops early after a step at which the energy ran away
  /// (sim/model_data.hpp, advance).
  void advance_to(double t, bool stop_on_runaway = false);

  /// Moves pinned vertices in straight lines at constant velocities from where they are to
  /// `targets` (one per vertex of `nodes`), arriving at time `arrival` (s, after now; for a
  /// fixed-step method rounded to a whole number of steps, one at least), where they stop. The
  /// solve sees the pins' velocities, so the cloth is pulled along smoothly. Their work on the
  /// cloth is not booked: it shows in EnergyRow::numerical_dissipated. A vertex moved again
  /// before it arrived starts its new move from where it is. Throws InputError naming the
  /// vertex that is not pinned, and for an arrival not after now or a non-finite target.
  void move_pins(const std::vector<int>& nodes, const std::vector<Vec3>& targets, double arrival);
  /// The pins still moving to their targets (move_pins).
  size_t moving_pins() const { return data_->pin_moves.size(); }
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
  double energy_scale() const { return data_->energy_scale; }
  /// Mechanical energy (kinetic + elastic + gravity) of the reference state (J).
  double initial_total_energy() const { return data_->total0; }

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
  std::shared_ptr<const Model> model_;
  const SimulationModel* m_;  ///< model_'s parts
  std::unique_ptr<SimulationData> data_;
  std::unique_ptr<ClothSystem> system_;     ///< a view of model_ and data_
  std::unique_ptr<Integrator> integrator_;  ///< a view of system_, model_ and data_
  /// `arrival` on the step grid from now (fixed-step methods); checks it is after now.
  double arrival_time(double arrival, const std::string& what) const;
};

}  // namespace weft
