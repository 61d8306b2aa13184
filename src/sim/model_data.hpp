#pragma once
// A simulation as a constant model and the data its steps change (docs/api.md, "Model and
// data"): SimulationModel is built once from a scene and never changed by a step;
// SimulationData holds everything a step reads and writes, and advance(model, data, t) steps
// it. Several SimulationData made from one SimulationModel are independent simulations of the
// same scene (each stepped by its own advance calls), and a checkpoint is a SimulationData
// written out (save_data). weft::Simulation and SimulationCore are this pair behind one
// object.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "integrate/integrator.hpp"
#include "system/cloth.hpp"
#include "weft/body.hpp"
#include "weft/simulation.hpp"

namespace weft {

class BinaryWriter;
class BinaryReader;
class Collider;
class ColliderContacts;
class SelfContacts;
class Clamps;

/// What a scene defines and no step changes.
struct SimulationModel {
  Scene scene;
  std::unique_ptr<ClothModel> cloth;   ///< the cloth's elements, masses and pins
  ClothSystem::Constants system;       ///< the elements packed for the step's passes
  Integrator::Constants integrator;    ///< the settings and what follows from them
  std::vector<std::unique_ptr<WalkingBody>> bodies;  ///< Scene::bodies order
  /// Per collider (Scene::colliders order): a mesh collider's triangles and vertices as the
  /// scene places them (before its motion); empty for the other shapes.
  std::vector<Triangles> collider_triangles;
  std::vector<Points> collider_vertices;
  std::vector<std::vector<int>> clamp_groups;  ///< per clamp (cloth.clamps), its vertices
  /// Per vertex: pinned or clamped (the contact handlers leave it where its motion puts it).
  std::vector<char> held;
  /// Per vertex, the smallest vertex it is sewn to (itself when none): the two sides of a
  /// seam do not push each other apart. Empty when the cloth has no seams.
  std::vector<int> seam_groups;
  /// The fastest the colliders' surfaces and the clamps move over the scene's duration (m/s,
  /// sampled at set-up from the scene's motions): the speed they may drive the cloth at, for
  /// the energy scale.
  double driving_speed = 0;

  int num_vertices() const { return cloth->num_vertices(); }
};

/// A pin on its way to a target (move_pins).
struct PinMove {
  int node;
  Vec3 target;
  double arrival;
};

/// What the steps of one simulation read and write. Not copyable: the integrator's contact
/// handlers point into it.
struct SimulationData {
  State state;
  StepStatistics statistics;
  ClothSystem::Data system;
  Integrator::Data integrator;
  /// Per collider, its rigid motion now (a scene's, or move_collider's).
  std::vector<RigidMotion> collider_motions;
  std::vector<std::unique_ptr<Collider>> colliders;  ///< with their per-step surfaces
  std::unique_ptr<ColliderContacts> contacts;        ///< null without colliders
  std::unique_ptr<SelfContacts> self_contacts;       ///< null when self_collision is off
  std::unique_ptr<Clamps> clamps;                    ///< null without clamps
  std::vector<PinMove> pin_moves;                    ///< move_pins: the pins on their way
  /// The energy reference: the gravitational and total mechanical energy of the reference
  /// state (J), and the scene's energy scale (SimulationCore::energy_scale).
  double gravity0 = 0, total0 = 0, energy_scale = 0;
  Evaluation eval;  ///< scratch for the energies

  SimulationData() = default;
  SimulationData(const SimulationData&) = delete;
  SimulationData& operator=(const SimulationData&) = delete;
  ~SimulationData();
};

/// Builds the model of `scene` (meshing and sewing a garment, building the elements, loading
/// bodies and collider meshes); throws InputError naming the scene for what does not fit.
std::unique_ptr<SimulationModel> build_model(const Scene& scene, const SetupProgress& on_setup = {});
/// A simulation of `model` at its start: the scene's initial state, as the energies' reference.
std::unique_ptr<SimulationData> make_data(const SimulationModel& model);
/// Advances `data` to time t (s), stopping pins on their targets when they arrive. With
/// `stop_on_runaway`, a fixed-step method stops early, after the step at which the cloth's
/// energy less the contacts' work rose by over IntegratorSettings::runaway_energy_factor energy scales (a blow-up
/// whose later steps could each take far longer than a frame: the caller's check of the state
/// then finds it unstable).
void advance(const SimulationModel& model, SimulationData& data, double t, bool stop_on_runaway = false);
/// Sets the velocity of pinned vertex i (and its BDF-2 history, as if it had moved so before).
void set_pin_velocity(const SimulationModel& model, SimulationData& data, int i, const Vec3& v);
/// Makes `data`'s state the reference of the energy accounting.
void set_energy_reference(const SimulationModel& model, SimulationData& data);
/// The energies of `data`'s state.
EnergyRow energies(const SimulationModel& model, SimulationData& data);
/// A hash of what a step's result depends on in the model: the mesh's positions, masses,
/// pins and pattern, the integrator settings and the damping.
std::uint64_t fingerprint(const SimulationModel& model);
/// Writes what later steps and the run's statistics depend on in `data`, bit for bit, after
/// the model's fingerprint.
void save_data(const SimulationModel& model, const SimulationData& data, BinaryWriter& out);
/// Reads what save_data wrote into `data`, a SimulationData of the same model; throws
/// InputError (through `in`) when the fingerprint or a size does not match.
void restore_data(const SimulationModel& model, SimulationData& data, BinaryReader& in);

}  // namespace weft
