#pragma once
// What an integrator sees: a mechanical system of n point masses that returns forces, their
// Jacobians K = df/dx and D = df/dv, and its energies. Integrators know nothing about cloth:
// the same integrator code steps a single spring and a garment.
#include <vector>

#include "linalg/aligned_allocator.hpp"
#include "linalg/block_sparse.hpp"

namespace weft {

/// One evaluation of the system at a state (x, v).
struct Evaluation {
  VecX force;                  ///< total force, 3n
  BlockMatrix stiffness;       ///< K = df/dx, made negative semi-definite (docs/method.md 1)
  BlockMatrix damping;         ///< D = df/dv, negative semi-definite
  double elastic_energy = 0;   ///< membrane + bending + springs (J)
  double gravity_energy = 0;   ///< gravitational potential (J), -sum m g.x
  double viscous_power = 0;    ///< f_viscous . v (W), <= 0
};

/// What one semi-implicit step needs, assembled in one pass: the forces, the step matrix
/// A = M - cd D - ck K (docs/method.md 1-2) and the product K w for the right-hand side.
struct StepAssembly {
  double ck = 0, cd = 0;       ///< alpha^2 dt_b^2 and alpha dt_b
  VecX force;                  ///< f, 3n
  BlockMatrix matrix;          ///< A
  VecX stiffness_times_w;      ///< K w
  double elastic_energy = 0, gravity_energy = 0, viscous_power = 0;
  /// What a system keeps from the assembly for step_viscous_power (empty: nothing).
  AlignedVector<double> element_data;
  Evaluation scratch;          ///< used by the generic implementation
};

class System {
 public:
  virtual ~System() = default;
  virtual int num_nodes() const = 0;
  /// Lumped mass per node (kg), n entries.
  virtual const VecX& node_mass() const = 0;
  /// Per-node constraint filter: 1 = the node does not move (pinned).
  virtual const std::vector<char>& pinned() const = 0;
  virtual const BlockPattern& pattern() const = 0;
  /// The order in which Gauss-Seidel-type solvers should take the nodes (a permutation,
  /// neighbours close together); null for the nodes' own numbering.
  virtual const std::vector<int>* solver_order() const { return nullptr; }
  /// Called once at the start of every step with the step's size (adaptive damping).
  virtual void begin_step(const VecX& /*x*/, const VecX& /*v*/, double /*dt*/) {}
  /// Fills `out` (force and energies always; Jacobians when `jacobians`), sizing what it
  /// fills as needed (an evaluation without Jacobians need not allocate the matrices).
  virtual void evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) = 0;
  /// The elastic and gravitational energy at x (J), the same numbers evaluate reports. The
  /// generic version evaluates; systems may compute them without the forces.
  virtual void potential_energy(const VecX& x, double& elastic, double& gravity);

  /// Fills `out` for coefficients out.ck, out.cd and the vector w. The generic version
  /// evaluates K and D and combines them; systems may fuse the work.
  virtual void assemble_step(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out);
  /// Power of the viscous forces at (x, v) (W, <= 0).
  virtual double viscous_power(const VecX& x, const VecX& v);
  /// The same power where x holds the positions `assembly` was last assembled at (by this
  /// system's assemble_step): a system may reuse what the assembly computed there.
  virtual double step_viscous_power(const VecX& x, const VecX& v, const StepAssembly& /*assembly*/) {
    return viscous_power(x, v);
  }

  /// Sets `out`'s matrices on this system's pattern.
  void prepare(Evaluation& out) const {
    out.force.resize(3 * num_nodes());
    out.stiffness.reset(pattern());
    out.damping.reset(pattern());
  }
};

}  // namespace weft
