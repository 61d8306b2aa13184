#pragma once
// Time integrators (docs/method.md 1-2). All semi-implicit methods share one linear step:
//   (M - alpha dt_b D - alpha^2 dt_b^2 K) dv = beta M dv_p + dt_b f + alpha dt_b K (beta dx_p + dt_b v)
//   dx = beta dx_p + dt_b (v + alpha dv)
// with beta = 0, dt_b = dt for the alpha family (forward Euler alpha = 0, Implicit Midpoint
// 1/2, backward Euler 1) and beta = (2 alpha - 1)/(2 alpha + 1), dt_b = 2 dt/(2 alpha + 1)
// for progressive BDF-2. RK4 and adaptive Dormand-Prince RK45 are the explicit references.
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "integrate/contact.hpp"
#include "linalg/mprgp.hpp"
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
/// kGuardMaxSplits halvings, after the scene's own (only those above it). 0.6 keeps a second-order-like accuracy (docs/method.md 3: the step is
/// stable when lambda > (1 - 2 alpha) kappa, so alpha 0.6 needs no damping at all), 1 is
/// backward Euler, stable whatever the stiffness.
constexpr double kGuardAlphas[] = {0.6, 0.75, 1.0};
/// A step puts energy in when its mechanical energy change plus its viscous work exceeds the
/// contacts' work by more than this fraction of the energy scale (Integrator::set_energy_scale,
/// or the state's kinetic plus elastic energy where larger).
constexpr double kGuardTolerance = 1e-4;
/// In the guarded midpoint (not the guarded BDF-2, whose own dissipation takes it out), the
/// fail-safes' work in a step (State::fail_safe_work) counts as energy the step put in when it
/// exceeds this fraction of the same scale: a solve that keeps driving nodes into what the
/// fail-safes push them out of is then taken again at a larger alpha, which dissipates the
/// fight instead of keeping it (docs/guarded-midpoint.md).
constexpr double kGuardFailSafeShare = 0.05;
/// How many times a guarded step that puts energy in is halved before alpha is raised.
constexpr int kGuardMaxSplits = 4;
/// Newton iterations of a guarded midpoint step's last resort (alpha at its top, halving
/// done) that still puts energy in, where the scene asks for none: a stiffening fabric's
/// linearised step overshoots into the steep part of its stress curve, which neither a smaller
/// step nor a larger alpha remove (docs/guarded-midpoint.md, "The last resort, iterated").
constexpr int kGuardLastResortNewton = 2;
/// Only a last resort that puts in more than this share of the energy scale is iterated (one
/// that puts in less is kept as it is: the run's energy rule stops runs at the whole scale).
constexpr double kGuardLastResortShare = 0.05;
/// Newton iterations of an unguarded backward Euler step (the alpha family at 1) that put
/// energy in, where the scene asks for fewer: backward Euler's own step never does, so energy
/// it gains is the linearisation's error, which on a stiffening fabric grows into a blow-up
/// (the jersey of the paper's swing at 20 ms). The step is taken again with them.
constexpr int kBackwardEulerNewton = 4;
/// Only a backward Euler step that puts in more than this share of the energy scale is taken
/// again (rounding and the contacts' small exchanges stay below it).
constexpr double kBackwardEulerNewtonShare = 0.01;
/// Where contacts acted, a halved guarded step whose half puts in more than this share of the
/// energy the whole step put in is not halved further: halving does not slow the rate at which
/// that energy goes in (a contact pushing the cloth, not elements turning within the step), and
/// the step is taken whole at larger alphas instead. Where the midpoint's stiff, turning
/// elements put the energy in, a half puts in at most 0.17 of the whole's on the 21x21 swing,
/// and less than nothing in most halvings (docs/guarded-midpoint.md).
constexpr double kGuardFutileShare = 0.25;
/// Steps without a redo after which a raised alpha goes down one rung.
constexpr int kGuardRelaxSteps = 5;

/// Solves per step at most while contacts change (Integrator::linear_step's active set): a
/// second solve takes the nodes the first would leave inside a collider and lets go of
/// contacts that pull; what a third would find, the contact fail-safe corrects (on the 65x65
/// sphere drop a third solve costs 12% more time and changes no contact the fail-safe would
/// not; docs/collisions.md).
constexpr int kMaxContactPasses = 2;
/// Times Newton's iterations (IntegratorSettings::newton_iterations) check where the free
/// nodes now end and add those that would end inside a collider's thickness to the contacts.
constexpr int kNewtonContactRounds = 2;
/// A linearised solve (unguarded, holding contacts) whose end, before the fail-safes, holds
/// more mechanical energy than its start by more than this fraction of the energy scale
/// (beyond the viscous and contacts' work) overshot up a stiffening stress curve: wrung cloth
/// pressed into itself, where the fail-safes would take most of it out again, or a sheet's
/// first impact. The step is taken again as two halves, as one the handlers could not make
/// valid (docs/collisions.md, "Solves that overshoot are taken again as halves").
constexpr double kSolveGainLimit = 0.1;
/// Rounds of the fail-safes after the first, where several handlers correct a step (the
/// colliders' and the cloth's own): each gives the first handler the nodes the others moved.
/// A step whose first handler still moves nodes in the last round is reported invalid.
constexpr int kFailSafeRounds = 3;
/// A contact is let go when it pulls with an impulse that would change its node's velocity by
/// more than this (m/s): below, the node stays held (at most 0.2 m/s^2 of adhesion at 5 ms
/// steps), which keeps resting contacts from being let go and taken back step after step.
constexpr double kReleaseSpeed = 1e-3;
/// Data::contact_stuck's mark of a contact held stuck by a bounded solve whose impulse left the
/// friction cone: it slides from the next step on (ContactSolve::kBounds).
constexpr char kSlipped = 2;
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
  /// The fixed-step methods' own clock: the sum of the steps taken. `t` is set to each
  /// requested end time exactly (Integrator::advance), which may differ from this sum in the
  /// last bits; the steps go on from the sum, so that how a run is cut into calls (how often
  /// frames are written) does not change it. Used only while within a step's millionth of `t`
  /// (a time set from outside restarts the clock there).
  double step_clock = 0;
};


/// Steps a System. Split as a simulation is (docs/api.md, "Model and data"): Constants (the
/// settings and what follows from them and the system: the preconditioner, the guard's alphas,
/// the mass per coordinate), never changed by a step, and Data, everything the steps read and
/// write beyond the State: the warm-start history, the guard's rung, the contact flags, the
/// solver's residual ratio and multigrid hierarchy, the contact handlers and all scratch. An
/// Integrator made from settings owns both; one made from Constants and Data is a view that
/// steps that Data.
class Integrator {
 public:
  struct Constants {
    IntegratorSettings settings;
    Preconditioner preconditioner = Preconditioner::kBlockJacobi;
    VecX mass3;  ///< mass per coordinate
    /// The guard's rungs: the scene's alpha, then the kGuardAlphas above it.
    std::vector<double> guard_alphas;
  };
  struct Data {
    /// Warm-start history (checkpointed) and the linear step its solves belong to (alpha,
    /// beta, dt_b) and the time they reached: another step size or a state from elsewhere
    /// starts it afresh.
    SolutionHistory history;
    double history_alpha = -1, history_beta = 0, history_dt_b = 0, history_t = 0;
    /// The solver's workspace; its SSOR residual ratio and single-precision fallbacks and its
    /// multigrid hierarchy outlive a step.
    PcgWorkspace pcg;
    BoundedSolveWorkspace bounded;       ///< ContactSolve::kBounds
    std::vector<NodeBound> bounds;       ///< the contacts' bounds of the bounded solve
    std::vector<int> bound_contact;      ///< per bound: its contact
    std::vector<char> bound_active, bound_held;
    std::vector<char> bound_free;        ///< per contact: 1 its normal's bound free, 2 its second's
    /// The matrix the multigrid hierarchy was built from (checkpointed: its aggregates follow
    /// that matrix's strong couplings, so a hierarchy built from a later matrix would solve
    /// differently); empty until one is built.
    std::vector<Mat3> multigrid_setup_blocks;
    /// Per node: its contact pulled at the previous step (released unless penetrating).
    std::vector<char> pulling;
    /// Per node: ended the last step stuck to a surface by friction (starts this one stuck).
    std::vector<char> stuck;
    int guard_rung = 0;        ///< the guard's alpha: its index in the rungs (0: the scene's)
    int guard_calm_steps = 0;  ///< steps since the guard last raised or lowered it
    int guard_depth = 0;       ///< halvings the next guarded step starts with
    int guard_depth_calm_steps = 0;  ///< steps since the depth last changed
    double energy_scale = 0;   ///< set_energy_scale

    /// The contact handlers, asked in the order added (add_contact_handler).
    std::vector<ContactHandler*> handlers;

    // Scratch, rewritten by every step.
    Evaluation eval;
    StepAssembly step;
    VecX rhs, dv;
    VecX w;              ///< the vector the assembly multiplies K by: beta dx_p + dt_b v
    VecX x_end;          ///< where the linearised step would end (the contacts' end detection)
    VecX mean_velocity;  ///< the step's dx/dt (the viscous work's accounting)
    VecX x_forces;       ///< where a Newton-iterated step evaluated its forces: x + alpha dx
    bool last_step_ok = true;  ///< the handlers' verdict on the last step
    /// linear_step's start, for the solve's energy gain (kSolveGainLimit): kinetic energy,
    /// viscous and contacts' work so far (J)
    double start_kinetic = 0, start_viscous = 0, start_contact_work = 0;
    int retry_depth = 0;
    std::vector<NodeContact> contacts;   ///< this step's, held by the solve
    std::vector<Vec3> contact_dv;        ///< the prescribed part of dv per contact
    std::vector<Vec3> contact_impulse;   ///< the constraint's impulse per contact (N s)
    std::vector<char> contact_stuck;     ///< per contact: sticking (all of dv prescribed), or kSlipped
    std::vector<Vec3> contact_rhs;       ///< the unconstrained right-hand side at each contact
    /// Blocks the constraints changed (slot, original value), and per slot whether saved.
    std::vector<std::pair<int, Mat3>> saved_blocks;
    std::vector<char> slot_saved;
    std::vector<char> held;          ///< per node: held by a contact this pass
    std::vector<char> released_now;  ///< per node: let go in this step
    std::vector<char> keep_held;     ///< per node: let go and back in this step: held to its end
    VecX x_start, rhs_unconstrained;
    VecX energy_x;  ///< potential_energy's last positions
    double energy_elastic = 0, energy_gravity = 0;  ///< and its answer there
    State guard_start;              ///< the guarded step's start, to take it again from
    double guard_gain = 0;          ///< the energy the last checked attempt put in (J)
    double guard_scale = 0;         ///< and the energy scale it was weighed against (J)
    /// What the first attempt of the last guarded step (or part) to return put in (J): its
    /// caller weighs a halving's parts against the whole.
    double guard_first_gain = 0;
    bool guard_raised_now = false;  ///< a part of this step was taken above the scene's alpha
    VecX v_before_fail_safe;               ///< finish_contacts: the velocities before every correction
    VecX x_before_fail_safe, v_before_group;  ///< finish_contacts: the state before one group of handlers
    VecX x_round;                           ///< finish_contacts: the positions the first handler left
    std::vector<ContactHandler*> handler_group;  ///< finish_contacts: the handlers of one group
    StepAssembly newton_step;  ///< newton_iterate's assembly (step keeps the step start's)
    /// Newton iterations for the linear steps taken now, when more than the settings' (the
    /// guard's last resort, kGuardLastResortNewton); 0 otherwise.
    int newton_now = 0;
    VecX newton_x, newton_v, newton_r, newton_r_trial, newton_dv_trial, newton_delta, newton_w;
    VecX newton_rhs;                ///< the residual filtered by the contacts
    std::vector<int> contact_slot;  ///< per node: its contact this step, or -1
  };
  static Constants make_constants(const System& system, IntegratorSettings settings);
  /// A fresh Data for stepping `system` with these constants: no history, no handlers.
  static Data make_data(const System& system, const Constants& constants);

  /// An integrator that owns its Constants and Data.
  Integrator(System& system, IntegratorSettings settings);
  /// A view stepping `data` (all three must outlive it).
  Integrator(System& system, const Constants& constants, Data& data);

  /// Advances `state` to time `t_end`: fixed-step methods take round((t_end - t)/dt) steps
  /// of dt; RK45 takes adaptive steps no longer than dt and lands on t_end exactly.
  void advance(State& state, double t_end, StepStatistics& stats);
  /// One step of size dt (fixed-step methods).
  void step(State& state, double dt, StepStatistics& stats);
  const IntegratorSettings& settings() const { return c_.settings; }
  const Constants& constants() const { return c_; }
  Data& data() { return d_; }
  const Data& data() const { return d_; }
  /// Contact handling for later steps, the handlers asked in the order added. Semi-implicit
  /// steps with alpha > 0 hold the detected contacts as constraints in the linear solve
  /// (docs/collisions.md); every method runs the handlers' fail-safes after each step, and
  /// takes a step they could not make valid again as two halves.
  void add_contact_handler(ContactHandler* handler) { d_.handlers.push_back(handler); }
  /// The preconditioner the linear solves use.
  Preconditioner preconditioner() const { return c_.preconditioner; }
  /// The SSOR relaxation the solves use (the setting, or the automatic one for this system).
  double ssor_relaxation() const;
  /// The energy (J) the guard's tolerance is a fraction of: the scene's energy scale.
  void set_energy_scale(double e) { d_.energy_scale = e; }
  /// The alpha the next guarded step starts from.
  double guard_alpha() const;
  /// Checks the checkpointed part of the Data against this system and settings and rebuilds
  /// what follows from it (the multigrid hierarchy from its matrix); throws
  /// std::invalid_argument for a Data that does not fit.
  void restored();

 private:
  PcgSettings pcg_settings() const;
  void single_step(State& s, double dt, StepStatistics& stats);
  /// An alpha-family step checked by the energy guard, taken again with larger alphas until
  /// it puts no energy in (or alpha reaches 1).
  /// `parent_gain`: for the first half of a halved step, the energy the whole step put in;
  /// false (s back at its start, nothing counted) when this half's first attempt put in more
  /// than kGuardFutileShare of it.
  bool guarded_step(State& s, double dt, StepStatistics& stats, int splits,
                    double parent_gain = std::numeric_limits<double>::infinity());
  /// A guarded step of dt as 2^depth parts (Data::guard_depth).
  void guarded_parts(State& s, double dt, StepStatistics& stats);
  /// A BDF-2 step checked by the energy guard: taken again with the next larger alpha of
  /// the guard's alphas, past them as a backward Euler step (the rung after the last alpha),
  /// and then as backward Euler halves.
  void guarded_bdf2_step(State& s, double dt, StepStatistics& stats);
  /// The step from the saved start guard_start to s put more energy in than the guard's
  /// tolerance (or ended non-finite); the step's assembly holds the start's energies.
  bool puts_energy_in(const State& s);
  /// An unguarded backward Euler step, taken again with kBackwardEulerNewton Newton
  /// iterations where it put in more than kBackwardEulerNewtonShare of the energy scale and the
  /// settings ask for fewer (IntegratorSettings::backward_euler_newton).
  void backward_euler_step(State& s, double dt, StepStatistics& stats);
  /// One BDF-2 step at the given alpha (docs/method.md 2); the first step of a run, with no
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
  /// positions (Data::energy_x; forgotten at the start of every advance).
  void potential_energy(const VecX& x, double& elastic, double& gravity);
  /// A semi-implicit step of the alpha family or BDF-2 (beta, dt_b; docs/method.md 1-2), as its
  /// stages below.
  void linear_step(State& s, double dt, double alpha, double beta, double dt_b, StepStatistics& stats);
  /// The step's matrix M - alpha dt_b D - alpha^2 dt_b^2 K and right-hand side (Data::step, rhs).
  void assemble_linear_step(const State& s, double dt, double alpha, double beta, double dt_b,
                            StepStatistics& stats);
  /// Data::dv's first guess: the solution history's, else the last change of velocity.
  void warm_start(const State& s, double alpha, double beta, double dt_b);
  /// The contacts at the step's start (Data::contacts), and which of them start stuck.
  void detect_contacts(const State& s, double dt, double alpha, StepStatistics& stats);
  /// Data::dv: the solve holding the contacts, as an active set (solved again while contacts
  /// change, kMaxContactPasses at most) or as bounds.
  void solve_with_contacts(const State& s, double dt, double alpha, double beta, double dt_b,
                           StepStatistics& stats);
  /// After a pass: contacts that pull let go, slips, nodes that would end inside joined;
  /// whether the set changed (and the step must be solved again).
  bool update_active_set(const State& s, double dt, double alpha, double beta, double dt_b, int pass,
                         bool bounded, StepStatistics& stats);
  /// x, v and the history moved by the solved step, and its viscous work booked.
  void take_step(State& s, double dt, double alpha, double beta, double dt_b, int newton_iterations);
  /// An alpha-family step's dx_prev and Data::dv scaled down to IntegratorSettings::max_step_motion.
  void limit_step_motion(State& s, double alpha);
  /// Newton iterations a linear step takes now (the settings', or the guard's last resort's).
  int newton_limit() const { return std::max(c_.settings.newton_iterations, d_.newton_now); }
  /// Newton iterations on the step's equations from the linearised solution in Data::dv
  /// (IntegratorSettings::newton_iterations); returns how many changed it.
  int newton_iterate(const State& s, double dt, double alpha, double beta, double dt_b, StepStatistics& stats);
  /// The residual r = beta M dv_p + dt_b f(x_a, v_a) - M dv of the step's equations at dv, with
  /// x_a = x + alpha (beta dx_p + dt_b (v + alpha dv)), v_a = v + alpha dv (left in
  /// Data::newton_x, newton_v); zero at pinned nodes. Returns |M^-1/2 r|.
  double newton_residual(const State& s, double alpha, double beta, double dt_b, const VecX& dv, VecX& r);
  void rk4_step(State& s, double dt, StepStatistics& stats);
  bool rk45_try(State& s, double h, double& error_norm, StepStatistics& stats);
  void derivative(const VecX& x, const VecX& v, VecX& a, double& viscous_power);
  /// Turns the step's system A dv = rhs into the one for the contacts' free directions
  /// (docs/collisions.md); sets dv's prescribed normal components in Data::contact_dv.
  void constrain(const State& s, double dt, double alpha, double beta, double dt_b);
  /// ContactSolve::kBounds: the step's solve with its contacts as bounds (stuck and kinematic
  /// ones held), the contacts whose bounds the answer leaves let go; the impulses into
  /// Data::contact_impulse.
  PcgResult bounded_pass(const State& s, double dt, double alpha, double beta, double dt_b, StepStatistics& stats);
  /// Data::contact_impulse from dv: what A dv - b leaves at each contact's node.
  void contact_impulses(double dt, double dt_b);
  /// After the last bounded pass: contacts whose bounds the answer left are let go (a second
  /// direction alone, or the whole contact).
  void release_inactive_bounds(StepStatistics& stats);
  /// The contacts' filters applied to a step matrix (S A S, with c (I - S) on the held
  /// directions); save(slot) is called before a block is changed.
  template <class Save>
  void filter_matrix(BlockMatrix& matrix, const Save& save) const;
  /// The same, keeping nothing (a matrix that is rebuilt before its next use).
  void filter_matrix(BlockMatrix& matrix) const;
  /// Appends the nodes not held that the step with Data::dv would end inside a collider's
  /// thickness (at Data::x_end) to the contacts; returns the count before.
  size_t join_end_contacts(const State& s, double dt, double alpha, double beta, double dt_b);
  /// Contact k's prescribed part z of dv: the held components that put the node where the
  /// contact prescribes.
  Vec3 prescribed_dv(const State& s, size_t k, double dt, double alpha, double beta, double dt_b) const;
  /// The filter S of contact k: I - n n^T sliding, 0 stuck.
  Mat3 contact_filter(size_t k) const;
  /// After the solve: dv completed with the prescribed components, the matrix restored,
  /// and the contact impulses into Data::contact_impulse.
  void unconstrain(double dt, double dt_b);
  /// Contact velocities after the step (inelastic normal, Coulomb friction) and their work.
  void contact_velocities(State& s, double dt, double dt_b);
  /// The handler's fail-safe on the step that went from Data::x_start.
  void finish_contacts(State& s, double t0, double dt, StepStatistics& stats);

  std::unique_ptr<Constants> own_constants_;  ///< when the integrator owns them
  std::unique_ptr<Data> own_data_;
  System& system_;
  const Constants& c_;
  Data& d_;
};

}  // namespace weft
