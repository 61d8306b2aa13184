#pragma once
// A piece of cloth as a mechanical system: membrane triangles, bending stencils, gravity
// and pinned vertices (docs/api.md, "Model and data": built once, never changed by a step).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "damping/adaptive.hpp"
#include "elements/bending.hpp"
#include "elements/membrane.hpp"
#include "elements/membrane_kernel.hpp"
#include "elements/plate_bending.hpp"
#include "mesh/mesh.hpp"
#include "system/system.hpp"
#include "weft/material.hpp"

namespace weft {

struct ClothModel {
  TriMesh mesh;              ///< rest pattern and initial positions
  /// The cloth's distinct materials, at least one: triangle t is made of
  /// materials[triangle_material[t]]. triangle_material is empty when there is one material
  /// (the usual cloth), so that the step's kernels take their one-material paths.
  std::vector<Material> materials;
  std::vector<int> triangle_material;  ///< #F indices into materials, or empty
  Vec3 gravity{0, -9.81, 0};  ///< m/s^2
  VecX mass;                 ///< lumped mass per vertex (kg)
  VecX inverse_mass;         ///< 0 on pinned vertices
  std::vector<char> pinned;  ///< pinned vertices (pins only; clamps are held, ModelData::held)
  std::vector<MembraneGeometry> membranes;     ///< one per mesh triangle
  std::vector<LinearBendingStencil> bending;   ///< bending elements (plate or hinge)
  BlockPattern pattern;
  std::vector<std::array<int, 9>> membrane_slots;   ///< block slots (i, j) row-major
  std::vector<std::vector<int>> bending_slots;      ///< k by k block slots per stencil
  std::vector<Vec3> membrane_mass_sums;             ///< per triangle (docs/method.md 4)
  std::vector<double> bending_mass_sums;            ///< kappa / dt^2 per stencil (docs/method.md 4)
  /// Sum of the stencils' Q_ij per block slot (i, j): the bending stiffness is -Q (x) I3,
  /// constant, so a step applies it as one pass over the pattern.
  std::vector<double> bending_slot_q;
  /// The vertices in bands across the pattern (banded_order): the order of the SSOR solves.
  std::vector<int> solver_order;

  int num_vertices() const { return mesh.num_vertices(); }
  /// The material of triangle t, and its index into materials.
  size_t material_index(size_t t) const {
    return triangle_material.empty() ? 0 : static_cast<size_t>(triangle_material[t]);
  }
  const Material& material_of(size_t t) const { return materials[material_index(t)]; }
  /// Initial positions as a 3n vector.
  VecX initial_positions() const;
};

/// Builds the model; `pins` are vertex indices. Throws InputError for a degenerate triangle
/// (naming its index and vertices), a bad pin index, or a non-positive density.
/// With a material per triangle (TriangleMaterials), each triangle's membrane and lumped
/// mass take its own material; a hinge between triangles of two materials takes the mean of
/// their bending rigidities (weft and warp each); the plate element takes one material only.
/// Materials with the same parameters (same_parameters) are merged.
/// Bending discretisation: the hinge element of docs/method.md 5 (default; one stencil per
/// interior edge) or the plate element (a quadratic fit per edge; exact energy for every
/// quadratic bend on any mesh; docs/fabric-validation.md compares them).
enum class BendingModel { kHinge, kPlate };
BendingModel parse_bending_model(const std::string& name, const std::string& where);

/// `seams` (mesh/mesh.hpp) become linear stencils beside the bending ones.
ClothModel build_cloth_model(TriMesh mesh, const Material& material, const Vec3& gravity,
                             const std::vector<int>& pins, BendingModel bending = BendingModel::kHinge,
                             const std::vector<Seam>& seams = {});
ClothModel build_cloth_model(TriMesh mesh, const TriangleMaterials& materials, const Vec3& gravity,
                             const std::vector<int>& pins, BendingModel bending = BendingModel::kHinge,
                             const std::vector<Seam>& seams = {});

struct DampingSettings {
  /// Target damping ratio (fraction of critical); 0 disables adaptive damping.
  double damping_ratio = 0.0;
  /// Step (s) at which the stiffness factors kappa and lambda are reported; 0 = each step's
  /// own dt. The added viscosity does not depend on the step (docs/method.md 4), so an adaptive
  /// method (RK45) given the scene's dt here reports factors comparable with a fixed-step run.
  double reference_dt = 0.0;
};


/// The cloth as the integrators see it (System). Its parts are split as a simulation is
/// (docs/api.md, "Model and data"): Constants, built once from the model and the damping
/// settings and never changed by a step, and Data, everything a step of the cloth reads and
/// writes (the viscosity in use, the damping statistics, caches keyed on the step). A
/// ClothSystem made from a model alone owns both; one made from Constants and Data is a view
/// that steps that Data (many Data may share one Constants, each stepped by its own view).
class ClothSystem : public System {
 public:
  /// Per-triangle constants packed for the step's passes, in triangle order.
  struct PackedTriangle {
    std::array<int, 3> vertex;
    /// Bit 3a + b set: this triangle is the first (in triangle order) to write block slot
    /// (a, b), so it assigns the block instead of adding to it.
    unsigned first_writer = 0;
    std::array<int, 9> slot;  ///< block slots (a, b), row-major
    /// Constants::bending_only_slots[begin, end): the slots, with no membrane block, of the
    /// rows this triangle is the first to touch; written with its blocks, while their cache
    /// lines are at hand.
    int bending_only_begin = 0, bending_only_end = 0;
    int material = 0;  ///< index into ClothModel::materials
    double ru[3], rv[3];
    double area;
  };
  /// Per material: its curves' moduli and the tangents the step's stiffness uses, for the
  /// linear paths (membrane::LinearCurves), and its viscosity.
  struct MaterialConstants {
    const Material* material;
    membrane::LinearCurves<double> linear;
    double viscosity;
  };
  /// Triangles per piece of the membrane pass (a multiple of 4).
  static constexpr int kMembranePiece = 256;
  /// What the steps never change.
  struct Constants {
    DampingSettings damping;
    std::vector<PackedTriangle> triangles;
    std::vector<int> bending_only_slots;  ///< block slots no membrane writes, by triangle
    /// Per block slot, 1 for those of bending_only_slots: their step-matrix blocks,
    /// ck Q + cd gamma Q, change only with ck and cd (BlockMatrix::constant_slots).
    std::vector<char> constant_slots;
    std::vector<MaterialConstants> material_constants;  ///< one per ClothModel::materials
    bool mixed = false;          ///< several materials
    bool linear_moduli = false;  ///< weft, warp and shear curves of every material all linear
    /// Bending damping time constant gamma (s) per stencil: damping force -gamma Q v.
    std::vector<double> bending_damping;
    std::vector<double> bending_slot_damping;  ///< sum of gamma Q_ij per block slot
    /// The membrane pass's pieces: triangles [first, second) of kMembranePiece (the last
    /// count % 4 triangles are not in any), ordered by group; a group's pieces share no
    /// vertex, so they run at once on the threads allowed, and the groups run one after the
    /// other (membrane_groups[g] is group g's first piece; a last entry closes the list).
    /// The pass takes the triangles in this order at every thread count, and the first
    /// writers of PackedTriangle follow it.
    std::vector<std::pair<int, int>> membrane_pieces;
    std::vector<int> membrane_groups;
  };
  /// What a step reads and writes. membrane_viscosity and statistics outlive a step
  /// (checkpoints write them); the rest are caches keyed on the step's dt, ck and cd that
  /// rebuild to the same values.
  struct Data {
    std::vector<Vec3> membrane_viscosity;  ///< per triangle and mode (N s/m), this step's
    DampingStatistics statistics;          ///< the run's
    /// The step matrix's constant_version after the last assembly, and its ck and cd.
    long constants_version = 0;
    double constants_ck = 0, constants_cd = 0;
    bool linear_viscosity_ready = false;  ///< membrane_viscosity holds the adaptive values
    double linear_stats_dt = -1;          ///< the dt of the membrane statistics below
    LogStatistics linear_kappa_step, linear_lambda_step, linear_added_step;
    long linear_raised_per_step = 0;
    LogStatistics bending_kappa_step;  ///< the stencils' kappa at bending_kappa_dt
    double bending_kappa_dt = -1;
    /// The assembly's energies and viscous powers per triangle and per node, written by the
    /// pieces and summed in index order afterwards (the same sums at every thread count).
    AlignedVector<double> triangle_energy, triangle_power;
    std::vector<double> node_gravity, node_bending, node_bending_power;
  };
  static Constants make_constants(const ClothModel& model, DampingSettings damping);
  /// A fresh Data: the materials' own viscosity, no statistics.
  static Data make_data(const ClothModel& model);

  /// A system that owns its Constants and Data.
  ClothSystem(const ClothModel& model, DampingSettings damping);
  /// A view stepping `data` (all three must outlive it).
  ClothSystem(const ClothModel& model, const Constants& constants, Data& data);

  int num_nodes() const override { return model_.num_vertices(); }
  const VecX& node_mass() const override { return model_.mass; }
  const std::vector<char>& pinned() const override { return model_.pinned; }
  const BlockPattern& pattern() const override { return model_.pattern; }
  const std::vector<int>* solver_order() const override { return &model_.solver_order; }
  void begin_step(const VecX& x, const VecX& v, double dt) override;
  void evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) override;
  void potential_energy(const VecX& x, double& elastic, double& gravity) override;
  /// Fused assembly: forces, step matrix and K w in one pass over the elements.
  void assemble_step(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) override;
  double viscous_power(const VecX& x, const VecX& v) override;
  /// viscous_power, taking the deformation gradients from the assembly when its batched
  /// membrane pass stored them (the same values, without gathering x again).
  double step_viscous_power(const VecX& x, const VecX& v, const StepAssembly& assembly) override;

  const ClothModel& model() const { return model_; }
  const Constants& constants() const { return c_; }
  Data& data() { return d_; }
  const Data& data() const { return d_; }
  const DampingSettings& damping_settings() const { return c_.damping; }
  /// Viscosity per triangle and mode (N s/m) in use for the current step.
  const std::vector<Vec3>& membrane_viscosity() const { return d_.membrane_viscosity; }
  /// Bending damping time constant gamma (s) per stencil: damping force -gamma Q v.
  const std::vector<double>& bending_damping() const { return c_.bending_damping; }
  /// Added viscosity per vertex (area-weighted mean over its triangles of the largest mode's
  /// addition), for colouring frames.
  VecX added_viscosity_per_vertex() const;
  const DampingStatistics& statistics() const { return d_.statistics; }
  /// Per-element stiffness factors kappa (largest mode) at a state, for analysis.
  std::vector<double> membrane_kappa_max(const VecX& x, double dt) const;

 private:
  /// Sets c's membrane pieces and groups; returns the order the membrane pass takes the
  /// triangles in (the pieces group by group, then the last count % 4 triangles).
  static std::vector<int> group_membrane_pieces(const ClothModel& model, Constants& c);
  /// The viscous power at (x, v); the batched triangles' deformation gradients U, V from
  /// `frames` (assemble_membranes_batched's StepAssembly::element_data) when not null.
  double viscous_power_with(const VecX& x, const VecX& v, const double* frames) const;
  /// assemble_step's work, in a non-virtual function so that it can be compiled per
  /// instruction set (linalg/dispatch.hpp).
  void assemble_step_kernel(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out);
  /// Sets the energies and adds gravity and the membrane forces to `force`; with `jacobians`
  /// calls `add_jacobians` per triangle with its result (9x9 blocks when `expand`).
  template <class AddJacobians>
  void add_gravity_and_membranes(const VecX& x, const VecX& v, bool jacobians, bool expand, VecX& force,
                                 double& elastic_energy, double& gravity_energy, double& viscous_power,
                                 const AddJacobians& add_jacobians) const;
  /// Adds the bending elements' forces, energy and viscous power, and with `jacobians` their
  /// K and D into `stiffness` and `damping`.
  void add_bending(const VecX& x, const VecX& v, bool jacobians, VecX& force, double& energy, double& viscous_power,
                   BlockMatrix* stiffness, BlockMatrix* damping) const;

  /// The arrays the membrane assembly reads and writes: positions, velocities, w; force,
  /// K w, matrix blocks; the bending Q and gamma Q per slot; the viscosity per triangle.
  struct MembraneArrays {
    const double *X, *Vel, *W;
    double *F, *KW;
    Mat3* blocks;
    const double *q, *qd;
    const Vec3* viscosity;
  };
  MembraneArrays membrane_arrays(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) const;
  /// The membranes' part of assemble_step: energies, forces, K w and the step matrix blocks
  /// (with the bending diagonal on each slot's first write); kLinear: all curves linear;
  /// kMixed: the triangles are of several materials (each reads its own constants).
  /// Triangles [begin, end); each triangle's energy and viscous power go to
  /// Data::triangle_energy and triangle_power.
  template <bool kLinear, bool kMixed>
  void assemble_membranes(const VecX& x, const VecX& v, const VecX& w, bool jacobians, size_t begin, size_t end,
                          StepAssembly& out) const;
  /// The same for triangles [begin, end) (multiples of 4), linear curves, with Jacobians: the
  /// element arithmetic of four triangles at a time in four-wide vectors; kMixed as above.
  template <bool kMixed>
  void assemble_membranes_batched(const VecX& x, const VecX& v, const VecX& w, size_t begin, size_t end,
                                  StepAssembly& out) const;
  /// Runs piece(begin, end) on every membrane piece, group after group (Constants::membrane_pieces).
  template <class Piece>
  void for_each_membrane_piece(const Piece& piece) const;
  /// assemble_step's per-node pass over nodes [begin, end): gravity and bending forces, K w
  /// and the nodes' energies and bending power (Data::node_gravity, ...).
  void assemble_nodes(const VecX& x, const VecX& v, const VecX& w, int begin, int end, StepAssembly& out) const;
  /// Adaptive viscosity and the per-step statistics of a material whose curves are all
  /// linear: the tangent moduli do not depend on the strain, so neither do they.
  void prepare_linear_damping(double dt);

  std::unique_ptr<Constants> own_constants_;  ///< when the system owns them
  std::unique_ptr<Data> own_data_;
  const ClothModel& model_;
  const Constants& c_;
  Data& d_;
};

}  // namespace weft
