#pragma once
// How a scene is integrated (docs/scene-format.md, "integrator"): the method, its
// implicitness, the step and the linear solves.
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace weft {

enum class Preconditioner {
  kBlockJacobi,  ///< inverse 3x3 diagonal blocks
  kMultigrid,    ///< one V-cycle of aggregation multigrid (linalg/multigrid.hpp)
  /// Symmetric block successive over-relaxation, M = (D/w + L) (D/w)^-1 (D/w + L^T), applied
  /// with Eisenstat's trick: an iteration costs two triangular solves over the lower half of A
  /// instead of a product plus the preconditioner.
  kSsor,
};

enum class Method { kForwardEuler, kAlphaFamily, kBdf2, kRk4, kRk45 };

/// Free nodes from which the automatic choice is multigrid rather than SSOR: below, SSOR's
/// iterations (two triangular solves each) win over the V-cycle's and the per-step coarse
/// operators; above, its iteration count keeps growing with the mesh while multigrid's
/// barely does (docs/performance.md).
constexpr int kMultigridMinFreeNodes = 30000;

/// How a semi-implicit step's contacts enter its linear solve (docs/collisions.md, "Contacts
/// as bounds"). kActiveSet: each detected contact prescribes its node's displacement along its
/// normal (a filter), and the step is solved again when a contact pulls or a free node would
/// end inside a collider. kBounds: each contact is a bound (the node ends at least at the
/// thickness) in one bounded solve, which lets go of the contacts that would pull by itself.
enum class ContactSolve { kActiveSet, kBounds };

/// The contact handling's tunables (scene key `contacts`, docs/scene-format.md). The defaults
/// were chosen on the shipped contact scenes (docs/notes/tunables.md, collisions.md).
struct ContactSettings {
  /// Thicknesses within which a node predicted to end near a collider is held in the solve.
  double hold_margin = 1.1;
  /// Speed (m/s) below which a node held against a collider counts as immovable to the
  /// cloth's own contacts.
  double held_rest_speed = 0.1;
  int self_passes = 4;        ///< passes of cloth-cloth impulses before impact zones take over
  int self_zone_rounds = 8;   ///< rounds of rigid impact zones before the zones are stopped
  /// Time (s, at least a step) over which a repulsion restores the missing thickness.
  double self_repulsion_time = 0.05;
  double self_hold_reach = 1.25;  ///< thicknesses out to which resting layers are held in the solve
  /// Relative speed (m/s) below which layers beyond the thickness are held.
  double self_hold_reach_speed = 0.5;
  /// Energy scales the collision fail-safes' work may pile up before a run counts as unstable
  /// (decides the run's status only, not its motion).
  double fail_safe_energy_factor = 100;
};

struct IntegratorSettings {
  Method method = Method::kAlphaFamily;
  double alpha = 0.5;               ///< implicitness (alpha family and BDF-2)
  double dt = 0.02;                 ///< step (s); for RK45 the largest step
  double cg_tolerance = 1e-6;       ///< relative residual of the linear solve
  int cg_max_iterations = 1000;
  /// Preconditioner of the conjugate-gradient solve; unset: chosen by the number of free nodes
  /// (docs/performance.md).
  std::optional<Preconditioner> preconditioner;
  double error_tolerance = 1e-6;    ///< RK45 local error tolerance (relative and absolute)
  /// SSOR relaxation in (0, 2); 0 chooses it from the mesh size (ssor_relaxation_for).
  double ssor_relaxation = 0.0;
  /// SSOR iterations in single precision (PcgSettings::ssor_single_precision): the same
  /// stopping rule on the true residual, 0.8-0.9 of the step time on the benchmark cloth.
  bool ssor_single_precision = true;
  /// Steps whose right-hand sides and solutions the linear solves' warm start combines
  /// (SolutionHistory); 0 starts each solve from the previous step's dv.
  int warm_start_history = 3;
  /// The energy guard (docs/guarded-midpoint.md): an alpha-family step that puts energy into
  /// the cloth is taken again from its start as two halves (4 times at most),
  /// then with a larger alpha (0.6, 0.75, then 1), which relaxes back to `alpha`. A BDF-2 step is
  /// taken again with a larger alpha (up to standard BDF-2, alpha = 1), then as a backward
  /// Euler step.
  bool guard = false;
  /// An unguarded semi-implicit step holding contacts whose solve overshoots (puts in more than
  /// a tenth of the energy scale) is taken again as two halves (docs/collisions.md, "Solves that
  /// overshoot are taken again as halves"). Off for the quasi-static sewing of garments, whose
  /// velocities are reset between intervals.
  bool halve_overshooting_solves = true;
  /// The guarded midpoint's last resort (alpha at its top, halving done) that still puts
  /// energy in is taken again with Newton iterations where `newton_iterations` asks for fewer
  /// (docs/guarded-midpoint.md, "The last resort, iterated"); off keeps the linearised one.
  bool guard_last_resort_newton = true;
  /// An unguarded backward Euler step (alpha family at 1) that puts in more than a hundredth
  /// of the energy scale is taken again with 4 Newton iterations where `newton_iterations` asks
  /// for fewer: its own step never puts energy in, so what it gains is the linearisation's
  /// error (a stiffening fabric). summary.json counts them (`newton.automatic_steps`). Scene
  /// key `integrator.automatic_newton`.
  bool backward_euler_newton = true;
  /// Newton iterations a semi-implicit step (alpha family, BDF-2) may add to its linearised
  /// solve: the step's nonlinear equations re-linearised at the
  /// iterate, with a backtracking line search. 0: one linearisation per step, as the paper's
  /// equations write the step. Steps that hold contacts in their solve stay linearised.
  int newton_iterations = 0;
  /// The iterations stop when the residual of the step's equations, as a change of velocity
  /// (|M^-1/2 r|), is below this fraction of the step's (|M^1/2 dv|, or of its right-hand
  /// side's |M^-1/2 b| where larger).
  double newton_tolerance = 1e-3;
  /// How contacts enter the solve (scene key `integrator.contact_solve`).
  ContactSolve contact_solve = ContactSolve::kActiveSet;
  /// How many times a step the contact handlers could not make valid is halved.
  int max_step_halvings = 3;
  /// The rise of the cloth's energy less the contacts' work, in energy scales, after which a
  /// run stops stepping early (above the one scale at which it is unstable; scene key
  /// `integrator.runaway_energy_factor`). Decides where a blown-up run stops, not its motion.
  double runaway_energy_factor = 1000;
  /// The most any node may move in one alpha-family step (m): a step that would move one
  /// farther has its displacement scaled down to this, its end velocity with it (the step's
  /// direction kept). For quasi-static relaxations, whose path does not matter (the sewing of
  /// garments: docs/garments.md, "Sewing"); a step scaled so does not follow the dynamics.
  /// Infinity (the default): never.
  double max_step_motion = std::numeric_limits<double>::infinity();
};

/// "auto", "block-jacobi", "ssor" or "multigrid"; nullopt for an unknown name.
std::optional<std::optional<Preconditioner>> parse_preconditioner(const std::string& name);
std::string preconditioner_name(Preconditioner p);

/// Method names accepted on the command line and in scenes, and their meaning.
struct MethodInfo {
  std::string name;
  Method method;
  std::optional<double> fixed_alpha;  ///< alpha implied by the name, if any
  double default_alpha;
  std::string description;
  bool guard = false;  ///< IntegratorSettings::guard
};
const std::vector<MethodInfo>& method_table();
/// Looks a method up by name; nullptr when unknown.
const MethodInfo* find_method(const std::string& name);
std::string method_names();  ///< "forward-euler, backward-euler, ..."

}  // namespace weft
