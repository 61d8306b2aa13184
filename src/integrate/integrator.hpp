#pragma once
// Time integrators (METHOD.md 1-2). All semi-implicit methods share one linear step:
//   (M - alpha dt_b D - alpha^2 dt_b^2 K) dv = beta M dv_p + dt_b f + alpha dt_b K (beta dx_p + dt_b v)
//   dx = beta dx_p + dt_b (v + alpha dv)
// with beta = 0, dt_b = dt for the alpha family (forward Euler alpha = 0, Implicit Midpoint
// 1/2, backward Euler 1) and beta = (2 alpha - 1)/(2 alpha + 1), dt_b = 2 dt/(2 alpha + 1)
// for progressive BDF-2. RK4 and adaptive Dormand-Prince RK45 are the explicit references.
#include <optional>
#include <string>
#include <vector>

#include "integrate/contact.hpp"
#include "linalg/pcg.hpp"
#include "linalg/solution_history.hpp"
#include "system/system.hpp"
#include "weft/settings.hpp"
#include "weft/statistics.hpp"

namespace weft {


/// Halvings of a Newton iteration's step (IntegratorSettings::newton_iterations) before the
/// line search gives up and the step keeps its last iterate.
constexpr int kNewtonMaxHalvings = 6;

/// The alphas a guarded step climbs through when a step puts energy in even after
/// kGuardMaxSplits halvings, after the scene's own (only those above it). 0.6 keeps a second-order-like accuracy (METHOD.md 3: the step is
/// stable when lambda > (1 - 2 alpha) kappa, so alpha 0.6 needs no damping at all), 1 is
/// backward Euler, stable whatever the stiffness.
constexpr double kGuardAlphas[] = {0.6, 0.75, 1.0};
/// A step puts energy in when its mechanical energy change plus its viscous work exceeds the
/// contacts' work by more than this fraction of the energy scale (Integrator::set_energy_scale,
/// or the state's kinetic plus elastic energy where larger).
constexpr double kGuardTolerance = 1e-4;
/// How many times a guarded step that puts energy in is halved before alpha is raised.
constexpr int kGuardMaxSplits = 4;
/// Steps without a redo after which a raised alpha goes down one rung.
constexpr int kGuardRelaxSteps = 5;

/// Solves per step at most while contacts change (Integrator::linear_step's active set): a
/// second solve takes the nodes the first would leave inside a collider and lets go of
/// contacts that pull; what a third would find, the contact fail-safe corrects (on the 65x65
/// sphere drop a third solve costs 12% more time and changes no contact the fail-safe would
/// not; docs/collisions.md).
constexpr int kMaxContactPasses = 2;
/// How many times a step the contact handlers could not make valid is halved.
constexpr int kMaxStepHalvings = 3;
/// A contact is let go when it pulls with an impulse that would change its node's velocity by
/// more than this (m/s): below, the node stays held (at most 0.2 m/s^2 of adhesion at 5 ms
/// steps), which keeps resting contacts from being let go and taken back step after step.
constexpr double kReleaseSpeed = 1e-3;
/// The preconditioner `settings` selects for a system with `free_nodes` unpinned nodes.
Preconditioner choose_preconditioner(const IntegratorSettings& settings, int free_nodes);


/// The integrators write into x and v in place: their storage stays the same from step to step
/// (the Python module's numpy arrays view it).
struct State {
  VecX x, v;             ///< positions (m) and velocities (m/s), 3n
  double t = 0;          ///< time (s)
  VecX dx_prev, dv_prev; ///< previous step's changes (BDF-2 history)
  bool has_history = false;
  double viscous_dissipated = 0;  ///< cumulative work done against viscous forces (J)
  /// Cumulative work of contact and friction forces on the cloth (J): negative when contacts
  /// took energy out (inelastic impacts, friction), positive when a moving collider put it in.
  double contact_work = 0;
  /// The part of contact_work the fail-safes did after the solves (J): their corrections'
  /// whole change of mechanical energy, clamps' included. A correction may put energy in that
  /// no force did, so the instability rule does not count it as work done on the cloth.
  double fail_safe_work = 0;
  double rk45_step = 0;           ///< RK45 step size carried between calls
};


class Integrator {
 public:
  Integrator(System& system, IntegratorSettings settings);
  /// Advances `state` to time `t_end`: fixed-step methods take round((t_end - t)/dt) steps
  /// of dt; RK45 takes adaptive steps no longer than dt and lands on t_end exactly.
  void advance(State& state, double t_end, StepStatistics& stats);
  /// One step of size dt (fixed-step methods).
  void step(State& state, double dt, StepStatistics& stats);
  const IntegratorSettings& settings() const { return settings_; }
  /// Contact handling for later steps, the handlers asked in the order added. Semi-implicit
  /// steps with alpha > 0 hold the detected contacts as constraints in the linear solve
  /// (docs/collisions.md); every method runs the handlers' fail-safes after each step, and
  /// takes a step they could not make valid again as two halves.
  void add_contact_handler(ContactHandler* handler) { handlers_.push_back(handler); }
  /// The preconditioner the linear solves use.
  Preconditioner preconditioner() const { return preconditioner_; }
  /// The SSOR relaxation the solves use (the setting, or the automatic one for this system).
  double ssor_relaxation() const;
  /// The energy (J) the guard's tolerance is a fraction of: the scene's energy scale.
  void set_energy_scale(double e) { energy_scale_ = e; }
  /// The alpha the next guarded step starts from.
  double guard_alpha() const;

  /// What later steps depend on beyond the State and the system (checkpoints): the warm-start
  /// history and the linear step it belongs to, the SSOR residual ratio the next solve
  /// starts from, and the matrix the multigrid hierarchy was built from (its aggregates
  /// follow that matrix's strong couplings, so a hierarchy built from a later matrix would
  /// solve differently). The rest of the integrator is scratch, rewritten by every step.
  struct DynamicState {
    SolutionHistory::Snapshot history;
    double history_alpha = -1, history_beta = 0, history_dt_b = 0, history_t = 0;
    double ssor_residual_ratio = 0;
    long ssor_single_fallbacks = 0;
    std::vector<Mat3> multigrid_setup_blocks;  ///< empty: no hierarchy built yet
    std::vector<char> contact_pulling;         ///< per node: its contact pulled (empty: none yet)
    std::vector<char> contact_stuck;           ///< per node: stuck by friction (empty: none yet)
    int guard_rung = 0;        ///< the guard's alpha: its index in the rungs (0: the scene's)
    int guard_calm_steps = 0;  ///< steps since the guard last raised or lowered it
    int guard_depth = 0;       ///< halvings the next guarded step starts with
    int guard_depth_calm_steps = 0;  ///< steps since the depth last changed
  };
  DynamicState dynamic_state() const;
  /// Restores a dynamic state taken from an integrator of the same system and settings
  /// (rebuilding the multigrid hierarchy from its matrix); throws std::invalid_argument
  /// for one that does not fit.
  void restore(const DynamicState& d);

 private:
  PcgSettings pcg_settings() const;
  void single_step(State& s, double dt, StepStatistics& stats);
  /// An alpha-family step checked by the energy guard, taken again with larger alphas until
  /// it puts no energy in (or alpha reaches 1).
  void guarded_step(State& s, double dt, StepStatistics& stats, int splits);
  /// A guarded step of dt as 2^depth parts (DynamicState::guard_depth).
  void guarded_parts(State& s, double dt, StepStatistics& stats);
  /// A BDF-2 step checked by the energy guard: taken again with the next larger alpha of
  /// guard_alphas_, past them as a backward Euler step (the rung after the last alpha), and
  /// then as backward Euler halves.
  void guarded_bdf2_step(State& s, double dt, StepStatistics& stats);
  /// The step from the saved start guard_start_ to s put more energy in than the guard's
  /// tolerance (or ended non-finite); the step's assembly holds the start's energies.
  bool puts_energy_in(const State& s);
  /// One BDF-2 step at the given alpha (METHOD.md 2); the first step of a run, with no
  /// history, is an alpha-family step.
  void bdf2_step(State& s, double dt, double alpha, StepStatistics& stats);
  /// Counts an accepted guarded step (or part) taken in `parts` parts at the guard's rung and
  /// lets the rung relax.
  void accept_guarded(double alpha, StepStatistics& stats, int parts = 1);
  /// A guarded BDF-2 step's last resort: a backward Euler step of dt from s, checked by the
  /// guard and taken again as two halves while it puts energy in (kGuardMaxSplits halvings
  /// at most, `splits` made so far); adds the parts taken to `parts`.
  void backward_euler_parts(State& s, double dt, StepStatistics& stats, int splits, int& parts);
  double kinetic_energy(const VecX& v) const;
  /// The system's elastic and gravitational energy at x, the last answer kept with its
  /// positions (energy_x_; forgotten at the start of every advance).
  void potential_energy(const VecX& x, double& elastic, double& gravity);
  void linear_step(State& s, double dt, double alpha, double beta, double dt_b, StepStatistics& stats);
  /// Newton iterations on the step's equations from the linearised solution in dv_
  /// (IntegratorSettings::newton_iterations); returns how many changed dv_.
  int newton_iterate(const State& s, double alpha, double beta, double dt_b, StepStatistics& stats);
  /// The residual r = beta M dv_p + dt_b f(x_a, v_a) - M dv of the step's equations at dv, with
  /// x_a = x + alpha (beta dx_p + dt_b (v + alpha dv)), v_a = v + alpha dv (left in newton_x_,
  /// newton_v_); zero at pinned nodes. Returns |M^-1/2 r|.
  double newton_residual(const State& s, double alpha, double beta, double dt_b, const VecX& dv, VecX& r);
  void rk4_step(State& s, double dt, StepStatistics& stats);
  bool rk45_try(State& s, double h, double& error_norm, StepStatistics& stats);
  void derivative(const VecX& x, const VecX& v, VecX& a, double& viscous_power);
  /// Turns the step's system A dv = rhs into the one for the contacts' free directions
  /// (docs/collisions.md); sets dv_'s prescribed normal components in contact_dv_.
  void constrain(const State& s, double dt, double alpha, double beta, double dt_b);
  /// The filter S of contact k: I - n n^T sliding, 0 stuck.
  Mat3 contact_filter(size_t k) const;
  /// After the solve: dv_ completed with the prescribed components, the matrix restored,
  /// and the contact impulses into contact_impulse_.
  void unconstrain(double dt, double dt_b);
  /// Contact velocities after the step (inelastic normal, Coulomb friction) and their work.
  void contact_velocities(State& s, double dt, double dt_b);
  /// The handler's fail-safe on the step that went from x_start_.
  void finish_contacts(State& s, double t0, double dt, StepStatistics& stats);

  System& system_;
  IntegratorSettings settings_;
  Evaluation eval_;
  StepAssembly step_;
  PcgWorkspace pcg_;
  Preconditioner preconditioner_ = Preconditioner::kBlockJacobi;
  VecX rhs_, dv_, tmp_, tmp2_;
  SolutionHistory history_;
  /// The linear step the history's solves belong to (alpha, beta, dt_b) and the time they
  /// reached: another step size or a state from elsewhere starts the history afresh.
  double history_alpha_ = -1, history_beta_ = 0, history_dt_b_ = 0, history_t_ = 0;
  VecX mass3_;  ///< mass per coordinate
  std::vector<Mat3> multigrid_setup_blocks_;  ///< DynamicState::multigrid_setup_blocks

  std::vector<ContactHandler*> handlers_;
  bool last_step_ok_ = true;  ///< the handlers' verdict on the last step
  int retry_depth_ = 0;
  std::vector<NodeContact> contacts_;   ///< this step's, held by the solve
  std::vector<Vec3> contact_dv_;        ///< the prescribed part of dv per contact
  std::vector<Vec3> contact_impulse_;   ///< the constraint's impulse per contact (N s)
  std::vector<char> contact_stuck_;     ///< per contact: sticking (all of dv prescribed)
  std::vector<Vec3> contact_rhs_;       ///< the unconstrained right-hand side at each contact
  /// Blocks the constraints changed (slot, original value), and per slot whether saved.
  std::vector<std::pair<int, Mat3>> saved_blocks_;
  std::vector<char> slot_saved_;
  /// Per node: its contact pulled at the previous step (released unless penetrating).
  std::vector<char> pulling_;
  /// Per node: ended the last step stuck to a surface by friction (starts this one stuck).
  std::vector<char> stuck_;
  std::vector<char> held_;        ///< per node: held by a contact this pass
  std::vector<char> released_now_;  ///< per node: let go in this step
  std::vector<char> keep_held_;     ///< per node: let go and back in this step: held to its end
  VecX x_start_, rhs_unconstrained_;

  double energy_scale_ = 0;  ///< set_energy_scale
  /// The guard's rungs: the scene's alpha, then the kGuardAlphas above it.
  std::vector<double> guard_alphas_;
  int guard_rung_ = 0, guard_calm_steps_ = 0;  ///< DynamicState::guard_rung, guard_calm_steps
  int guard_depth_ = 0, guard_depth_calm_steps_ = 0;  ///< DynamicState::guard_depth, ..._calm_steps
  VecX energy_x_;             ///< potential_energy's last positions
  double energy_elastic_ = 0, energy_gravity_ = 0;  ///< and its answer there
  State guard_start_;        ///< the guarded step's start, to take it again from
  bool guard_raised_now_ = false;  ///< a part of this step was taken above the scene's alpha
  VecX v_before_fail_safe_;                  ///< finish_contacts: the velocities before every correction
  VecX x_before_fail_safe_, v_before_group_; ///< finish_contacts: the state before one group of handlers
  StepAssembly newton_step_;  ///< newton_iterate's assembly (step_ keeps the step start's)
  VecX newton_x_, newton_v_, newton_r_, newton_r_trial_, newton_dv_trial_, newton_delta_, newton_w_;
};

}  // namespace weft
