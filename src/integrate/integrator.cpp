#include "integrate/integrator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace weft {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
}  // namespace

const std::vector<MethodInfo>& method_table() {
  static const std::vector<MethodInfo> table = {
      {"forward-euler", Method::ForwardEuler, 0.0, 0.0, "explicit Euler (alpha family, alpha = 0)"},
      {"implicit-midpoint", Method::AlphaFamily, 0.5, 0.5,
       "alpha family, alpha = 1/2 (second order), with the energy guard: a step that would put energy in "
       "is taken again as two halves, then with a larger alpha",
       true},
      {"implicit-midpoint-plain", Method::AlphaFamily, 0.5, 0.5,
       "alpha family, alpha = 1/2 (second order), without the energy guard (the paper's step)"},
      {"backward-euler", Method::AlphaFamily, 1.0, 1.0, "alpha family, alpha = 1 (first order, dissipative)"},
      {"alpha", Method::AlphaFamily, std::nullopt, 0.5, "alpha family with the given --alpha in [0, 1]"},
      {"bdf2", Method::Bdf2, 1.0, 1.0, "progressive BDF-2, alpha = 1 (standard BDF-2)"},
      {"bdf2-alpha", Method::Bdf2, std::nullopt, 1.0 / std::sqrt(3.0),
       "progressive BDF-2 with the given alpha (default 1/sqrt(3))"},
      {"bdf2-alpha-guarded", Method::Bdf2, std::nullopt, 1.0 / std::sqrt(3.0),
       "progressive BDF-2 with the given alpha (default 1/sqrt(3)) and the energy guard: a step that would "
       "put energy in is taken again with a larger alpha, up to standard BDF-2, then as a backward Euler step",
       true},
      {"rk4", Method::Rk4, std::nullopt, 0.0, "classical explicit Runge-Kutta, fourth order"},
      {"rk45", Method::Rk45, std::nullopt, 0.0,
       "adaptive explicit Dormand-Prince 5(4) with local error tolerance (reference)"},
  };
  return table;
}

const MethodInfo* find_method(const std::string& name) {
  for (const auto& m : method_table())
    if (m.name == name) return &m;
  return nullptr;
}

std::string method_names() {
  std::string s;
  for (const auto& m : method_table()) s += (s.empty() ? "" : ", ") + m.name;
  return s;
}

Integrator::Constants Integrator::make_constants(const System& system, IntegratorSettings settings) {
  Constants c;
  c.settings = settings;
  const int n = system.num_nodes();
  c.mass3.resize(3 * n);
  for (int i = 0; i < n; ++i) c.mass3.segment<3>(3 * i).setConstant(system.node_mass()[i]);
  int free_nodes = 0;
  for (char f : system.fixed()) free_nodes += f ? 0 : 1;
  c.preconditioner = choose_preconditioner(settings, free_nodes);
  c.guard_alphas = {settings.alpha};
  for (double a : kGuardAlphas)
    if (a > settings.alpha) c.guard_alphas.push_back(a);
  // BDF-2's guard climbs to alpha = 1 (standard BDF-2), then to backward Euler; a BDF-2 at
  // alpha = 1 already goes straight to backward Euler.
  if (settings.method == Method::Bdf2 && c.guard_alphas.back() < 1.0) c.guard_alphas.push_back(1.0);
  return c;
}

Integrator::Data Integrator::make_data(const System& system, const Constants& constants) {
  Data d;
  d.history = SolutionHistory(constants.settings.warm_start_history);
  d.step.matrix.reset(system.pattern());
  if (constants.settings.newton_iterations > 0) d.newton_step.matrix.reset(system.pattern());
  return d;
}

Integrator::Integrator(System& system, IntegratorSettings settings)
    : own_constants_(std::make_unique<Constants>(make_constants(system, settings))),
      own_data_(std::make_unique<Data>(make_data(system, *own_constants_))),
      system_(system),
      c_(*own_constants_),
      d_(*own_data_) {}

Integrator::Integrator(System& system, const Constants& constants, Data& data)
    : system_(system), c_(constants), d_(data) {}

double Integrator::ssor_relaxation() const {
  if (c_.settings.ssor_relaxation > 0) return c_.settings.ssor_relaxation;
  int free_nodes = 0;
  for (char f : system_.fixed()) free_nodes += f ? 0 : 1;
  return ssor_relaxation_for(free_nodes);
}

Preconditioner choose_preconditioner(const IntegratorSettings& settings, int free_nodes) {
  if (settings.preconditioner) return *settings.preconditioner;
  return free_nodes >= kMultigridMinFreeNodes ? Preconditioner::kMultigrid : Preconditioner::kSsor;
}

std::optional<std::optional<Preconditioner>> parse_preconditioner(const std::string& name) {
  if (name == "auto") return std::optional<Preconditioner>();
  if (name == "block-jacobi") return std::optional<Preconditioner>(Preconditioner::kBlockJacobi);
  if (name == "multigrid") return std::optional<Preconditioner>(Preconditioner::kMultigrid);
  if (name == "ssor") return std::optional<Preconditioner>(Preconditioner::kSsor);
  return std::nullopt;
}

std::string preconditioner_name(Preconditioner p) {
  switch (p) {
    case Preconditioner::kMultigrid:
      return "multigrid";
    case Preconditioner::kSsor:
      return "ssor";
    case Preconditioner::kBlockJacobi:
      break;
  }
  return "block-jacobi";
}

PcgSettings Integrator::pcg_settings() const {
  PcgSettings ps{c_.settings.cg_tolerance, c_.settings.cg_max_iterations, c_.preconditioner};
  ps.node_order = system_.solver_order();
  ps.ssor_omega = c_.settings.ssor_relaxation;
  ps.ssor_single_precision = c_.settings.ssor_single_precision;
  ps.ssor_whole_blocks = !d_.handlers.empty();
  return ps;
}

void Integrator::restored() {
  const BlockPattern& P = system_.pattern();
  if (!d_.multigrid_setup_blocks.empty()) {
    if (c_.preconditioner != Preconditioner::kMultigrid ||
        d_.multigrid_setup_blocks.size() != static_cast<size_t>(P.num_blocks()))
      throw std::invalid_argument("the multigrid matrix does not fit this system and preconditioner");
    BlockMatrix m;
    m.reset(P);
    m.block = d_.multigrid_setup_blocks;
    d_.pcg.multigrid.setup(m, system_.fixed(), pcg_settings().multigrid);
  }
  if (!d_.pulling.empty() && d_.pulling.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  if (!d_.stuck.empty() && d_.stuck.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  // BDF-2's guard has one rung past its alphas (backward Euler).
  const int rungs = static_cast<int>(c_.guard_alphas.size()) + (c_.settings.method == Method::Bdf2 ? 1 : 0);
  if (d_.guard_rung < 0 || d_.guard_rung >= rungs || d_.guard_calm_steps < 0)
    throw std::invalid_argument("the guard's alpha does not fit these settings");
  if (d_.guard_depth < 0 || d_.guard_depth > kGuardMaxSplits || d_.guard_depth_calm_steps < 0)
    throw std::invalid_argument("the guard's step depth does not fit these settings");
}

double Integrator::guard_alpha() const {
  return d_.guard_rung < static_cast<int>(c_.guard_alphas.size()) ? c_.guard_alphas[d_.guard_rung] : 1.0;
}

void Integrator::advance(State& s, double t_end, StepStatistics& stats) {
  const double dt = c_.settings.dt;
  d_.energy_x.resize(0);  // the system may have changed between calls
  if (c_.settings.method != Method::Rk45) {
    const long steps = std::lround((t_end - s.t) / dt);
    // The steps run on their own clock, the sum of their sizes, whatever the calls' end times
    // (State::step_clock); a time set from outside (far from the clock) restarts it.
    if (std::abs(s.step_clock - s.t) <= 1e-6 * dt) s.t = s.step_clock;
    for (long k = 0; k < steps; ++k) step(s, dt, stats);
    s.step_clock = s.t;
    s.t = t_end;
    return;
  }
  if (!(s.rk45_step > 0)) s.rk45_step = dt;
  while (s.t < t_end - 1e-12 * std::max(1.0, std::abs(t_end))) {
    double h = std::min({s.rk45_step, dt, t_end - s.t});
    double err = 0;
    if (rk45_try(s, h, err, stats)) {
      ++stats.steps;
      // Standard controller: h_new = h * 0.9 err^(-1/5), within [0.2, 5] h.
      const double factor = err > 0 ? std::clamp(0.9 * std::pow(err, -0.2), 0.2, 5.0) : 5.0;
      s.rk45_step = std::min(dt, h * factor);
      if (t_end - s.t < 1e-12 * std::max(1.0, std::abs(t_end))) s.t = t_end;
    } else {
      ++stats.rejected_steps;
      if (!std::isfinite(err)) {
        s.rk45_step = h * 0.2;
      } else {
        s.rk45_step = h * std::clamp(0.9 * std::pow(err, -0.2), 0.1, 0.9);
      }
      if (s.rk45_step < 1e-14) {
        // Cannot make progress: let the caller detect the blow-up.
        s.x.setConstant(std::nan(""));
        return;
      }
    }
  }
  s.t = t_end;
}

void Integrator::step(State& s, double dt, StepStatistics& stats) {
  if (d_.handlers.empty()) {
    single_step(s, dt, stats);
    return;
  }
  // A step the contact handlers could not make valid is taken again as two of half the size
  // (a few times at most; the last result stands).
  State start = s;
  const std::vector<char> pulling = d_.pulling, stuck = d_.stuck;
  d_.last_step_ok = true;
  const long failures = stats.cg_failures;
  single_step(s, dt, stats);
  if (d_.last_step_ok || d_.retry_depth >= kMaxStepHalvings) return;
  stats.cg_failures = failures;  // the attempt taken again does not count
  s = start;  // copied into s's own storage (State: x and v keep theirs)
  d_.pulling = pulling;
  d_.stuck = stuck;
  d_.history.clear();
  ++stats.halved_steps;
  ++d_.retry_depth;
  step(s, 0.5 * dt, stats);
  step(s, 0.5 * dt, stats);
  --d_.retry_depth;
  --stats.steps;  // the attempt that was taken again is not an accepted step
}

void Integrator::single_step(State& s, double dt, StepStatistics& stats) {
  const double alpha = c_.settings.alpha;
  switch (c_.settings.method) {
    case Method::ForwardEuler:
      linear_step(s, dt, 0.0, 0.0, dt, stats);
      break;
    case Method::AlphaFamily:
      if (c_.settings.guard) {
        guarded_parts(s, dt, stats);
      } else if (alpha == 1.0 && c_.settings.backward_euler_newton && newton_limit() < kBackwardEulerNewton) {
        backward_euler_step(s, dt, stats);
      } else {
        linear_step(s, dt, alpha, 0.0, dt, stats);
      }
      break;
    case Method::Bdf2:
      if (c_.settings.guard) {
        guarded_bdf2_step(s, dt, stats);
      } else {
        bdf2_step(s, dt, alpha, stats);
      }
      break;
    case Method::Rk4:
      rk4_step(s, dt, stats);
      break;
    case Method::Rk45: {
      double err;
      if (!rk45_try(s, dt, err, stats)) ++stats.rejected_steps;
      break;
    }
  }
  ++stats.steps;
}

void Integrator::potential_energy(const VecX& x, double& elastic, double& gravity) {
  // The guard asks for the energy at the very positions the contacts' fail-safe has just
  // measured: the last answer is kept with its positions.
  if (!(d_.energy_x.size() == x.size() && d_.energy_x == x)) {
    system_.potential_energy(x, d_.energy_elastic, d_.energy_gravity);
    d_.energy_x = x;
  }
  elastic = d_.energy_elastic;
  gravity = d_.energy_gravity;
}

void Integrator::backward_euler_step(State& s, double dt, StepStatistics& stats) {
  // The check's own work (saving the start, the end's energy) counts as the Newton iterations'.
  auto tg = Clock::now();
  d_.guard_start = s;
  const std::vector<char> pulling = d_.pulling, stuck = d_.stuck;
  stats.newton_seconds += seconds_since(tg);
  linear_step(s, dt, 1.0, 0.0, dt, stats);
  tg = Clock::now();
  puts_energy_in(s);
  const bool gained = !(d_.guard_gain <= kBackwardEulerNewtonShare * d_.guard_scale);
  stats.newton_seconds += seconds_since(tg);
  if (!gained) return;
  s = d_.guard_start;
  d_.pulling = pulling;
  d_.stuck = stuck;
  d_.newton_now = kBackwardEulerNewton;
  if (d_.newton_step.matrix.pattern == nullptr) d_.newton_step.matrix.reset(system_.pattern());
  linear_step(s, dt, 1.0, 0.0, dt, stats);
  d_.newton_now = 0;
  ++stats.newton_automatic_steps;
}

void Integrator::bdf2_step(State& s, double dt, double alpha, StepStatistics& stats) {
  if (!s.has_history) {
    linear_step(s, dt, alpha, 0.0, dt, stats);  // start with one alpha-family step
  } else {
    // docs/method.md 2: beta = (2 alpha - 1)/(2 alpha + 1), dt_b = 2 dt/(2 alpha + 1)
    linear_step(s, dt, alpha, (2 * alpha - 1) / (2 * alpha + 1), 2 * dt / (2 * alpha + 1), stats);
  }
}

double Integrator::kinetic_energy(const VecX& v) const {
  return 0.5 * c_.mass3.dot(v.cwiseAbs2());
}

// The energy balance of one step: with static pins, gravity the only external force and the
// contacts' work counted in State::contact_work, the mechanical energy can only fall by the
// viscous work and what contacts took (docs/method.md 6). Linearised Implicit Midpoint does not
// keep to it where elements are stiff and turn within the step (docs/guarded-midpoint.md): a
// step that breaks it is taken again from its start as two halves, and where a sixteenth of
// the step still breaks it, with the next larger alpha (numerical dissipation of order
// (2 alpha - 1), only while it is needed). The start's energy comes with the step's assembly;
// the end's costs one evaluation without Jacobians.
void Integrator::guarded_parts(State& s, double dt, StepStatistics& stats) {
  // A step the last steps had to halve starts halved as often (no attempt at the full step to
  // discard); the depth goes back up one halving after every kGuardRelaxSteps steps that needed
  // no deeper one.
  d_.guard_raised_now = false;
  const int depth = d_.guard_depth;
  const int parts = 1 << depth;
  for (int k = 0; k < parts; ++k) guarded_step(s, dt / parts, stats, depth);
  if (d_.guard_raised_now) ++stats.guard_raised_steps;
  if (d_.guard_depth > depth) {
    d_.guard_depth_calm_steps = 0;
  } else if (d_.guard_depth > 0 && ++d_.guard_depth_calm_steps >= kGuardRelaxSteps) {
    --d_.guard_depth;
    d_.guard_depth_calm_steps = 0;
  }
}

bool Integrator::guarded_step(State& s, double dt, StepStatistics& stats, int splits, double parent_gain) {
  auto tg = Clock::now();
  d_.guard_start = s;
  const std::vector<char> pulling = d_.pulling, stuck = d_.stuck;
  const auto restart = [&] {  // back to the step's start, its contact flags included
    s = d_.guard_start;
    d_.pulling = pulling;
    d_.stuck = stuck;
  };
  const int top = static_cast<int>(c_.guard_alphas.size()) - 1;
  bool may_halve = splits < kGuardMaxSplits;
  double first_gain = 0;
  for (bool first = true;; first = false) {
    const double alpha = c_.guard_alphas[d_.guard_rung];
    stats.guard_seconds += seconds_since(tg);
    const long failures = stats.cg_failures;
    linear_step(s, dt, alpha, 0.0, dt, stats);
    tg = Clock::now();
    const bool gained = puts_energy_in(s);
    if (first) first_gain = d_.guard_gain;
    if (!gained) break;
    const double gain = d_.guard_gain;
    stats.guard_seconds += seconds_since(tg);
    tg = Clock::now();
    // Only contacts (held nodes in the solve, or the fail-safes' moves) put energy in at a
    // rate halving does not slow; without them the step halves as far as it may.
    const bool contacts_acted = !d_.contacts.empty() || s.contact_work != d_.guard_start.contact_work;
    if (first && contacts_acted && gain > kGuardFutileShare * parent_gain) {
      // A half of a halved step put in more than kGuardFutileShare of what the whole step
      // did: halving does not slow the rate at which energy goes in (a contact pushing the
      // cloth, not the midpoint's stiff turning elements), and the caller takes the step (or
      // this half) whole at larger alphas instead.
      stats.cg_failures = failures;
      restart();
      stats.guard_seconds += seconds_since(tg);
      d_.guard_first_gain = first_gain;
      return false;
    }
    // The attempt is discarded unless it is the last resort kept below; a discarded attempt's
    // solves that stopped at the iteration cap are not counted as failures.
    if (may_halve || d_.guard_rung < top) stats.cg_failures = failures;
    if (!may_halve && d_.guard_rung == top) {
      if (!contacts_acted) break;
      // The last resort, kept: neither halving nor alpha removed what this step puts in (a
      // contact pressing the cloth). The next steps start whole again, as parts this fine
      // would only repeat it at more cost.
      d_.guard_depth = 0;
      d_.guard_depth_calm_steps = 0;
      // Where the scene iterates no step, it is taken once more with Newton iterations: what a
      // stiffening fabric's linearised step books as elastic energy past the start's tangent,
      // neither halving nor alpha remove, and the iterations do.
      if (c_.settings.guard_last_resort_newton && newton_limit() < kGuardLastResortNewton &&
          d_.guard_gain > kGuardLastResortShare * d_.guard_scale) {
        restart();
        d_.newton_now = kGuardLastResortNewton;
        if (d_.newton_step.matrix.pattern == nullptr) d_.newton_step.matrix.reset(system_.pattern());
        linear_step(s, dt, alpha, 0.0, dt, stats);
        d_.newton_now = 0;
        ++stats.guard_newton_steps;
        puts_energy_in(s);
      }
      break;
    }
    restart();
    if (may_halve) {
      // Halving the step divides kappa by 4 and the elements' turn within the step by 2 while
      // keeping the step second order: on the stiff swing it dissipates a third of what
      // raising alpha does (docs/guarded-midpoint.md).
      const int depth = d_.guard_depth;
      d_.guard_depth = std::max(d_.guard_depth, splits + 1);
      if (guarded_step(s, 0.5 * dt, stats, splits + 1, gain)) {
        ++stats.guard_split_steps;
        double halves_gain = d_.guard_first_gain;
        // The second half likewise; where it puts in as much as the whole did, it is taken
        // whole at larger alphas.
        if (!guarded_step(s, 0.5 * dt, stats, splits + 1, gain)) {
          ++stats.guard_futile_splits;
          halves_gain = std::numeric_limits<double>::infinity();
          guarded_step(s, 0.5 * dt, stats, kGuardMaxSplits);
        } else {
          halves_gain = std::max(halves_gain, d_.guard_first_gain);
        }
        // The next steps start as finely divided where the halving removed what the whole
        // step put in as stiff turning elements let it (each half a quarter of it at most:
        // they go on turning). Where contacts acted and the halves did not show it, what put
        // energy in came and went with the contacts, and the next steps are not divided for
        // it (unless the halves' own halvings did): at rest in a funnel's neck, halvings of
        // steps just over the tolerance had every step taken as 8 to 16 parts.
        if (contacts_acted && !(halves_gain <= kGuardFutileShare * gain) && d_.guard_depth == splits + 1)
          d_.guard_depth = depth;
        d_.guard_first_gain = first_gain;
        return true;
      }
      // Halving did not help: s is back at the start; the whole step again at the next
      // alpha (at the last one, that attempt is kept whatever it puts in).
      d_.guard_depth = depth;
      may_halve = false;
      ++stats.guard_futile_splits;
      if (d_.guard_rung == top) continue;
    }
    // Still putting energy in: a larger alpha, which stays raised for a few steps.
    ++d_.guard_rung;
    d_.guard_calm_steps = 0;
    ++stats.guard_redone_steps;
  }
  stats.guard_seconds += seconds_since(tg);
  accept_guarded(c_.guard_alphas[d_.guard_rung], stats);
  d_.guard_first_gain = first_gain;
  return true;
}

bool Integrator::puts_energy_in(const State& s) {
  const double kinetic0 = kinetic_energy(d_.guard_start.v);
  const double e0 = kinetic0 + d_.step.elastic_energy + d_.step.gravity_energy;
  const double scale = std::max(d_.energy_scale, kinetic0 + d_.step.elastic_energy);
  double elastic1, gravity1;
  potential_energy(s.x, elastic1, gravity1);
  const double e1 = kinetic_energy(s.v) + elastic1 + gravity1;
  double gain = (e1 - e0) + (s.viscous_dissipated - d_.guard_start.viscous_dissipated) -
                (s.contact_work - d_.guard_start.contact_work);
  // The fail-safes' corrections are contact work, but where they put in a sizeable share of
  // the scale in one step it is the solve's fight with them, which the midpoint would keep
  // (BDF-2 dissipates it: its guard leaves the fail-safes' work out).
  const double fail_safe = s.fail_safe_work - d_.guard_start.fail_safe_work;
  if (c_.settings.method == Method::AlphaFamily && fail_safe > kGuardFailSafeShare * scale) gain += fail_safe;
  d_.guard_gain = gain;
  d_.guard_scale = scale;
  // A non-finite end is a step that put energy in too.
  return !(gain <= kGuardTolerance * scale);
}

void Integrator::accept_guarded(double alpha, StepStatistics& stats, int parts) {
  stats.guard_parts += parts;
  if (d_.guard_rung > 0) {
    d_.guard_raised_now = true;
    stats.guard_max_alpha = std::max(stats.guard_max_alpha, alpha);
    if (++d_.guard_calm_steps >= kGuardRelaxSteps) {
      --d_.guard_rung;
      d_.guard_calm_steps = 0;
    }
  }
}

// The guard for BDF-2 (alpha family of BDF-2 steps, docs/method.md 2): the same energy balance as
// guarded_step. A step that breaks it is taken again from its start with the next larger alpha
// (up to alpha = 1, standard BDF-2, whose numerical dissipation of fast modes is strongest),
// and past that as a backward Euler step, which needs no history; where even that puts energy
// in, as backward Euler halves (backward_euler_parts). BDF-2 steps themselves are not halved:
// their history holds the last step's displacement and change of velocity at the step's own
// size. The rung reached stays for the next steps and relaxes as in guarded_step.
void Integrator::guarded_bdf2_step(State& s, double dt, StepStatistics& stats) {
  auto tg = Clock::now();
  d_.guard_start = s;
  const std::vector<char> pulling = d_.pulling, stuck = d_.stuck;
  const int backward_euler = static_cast<int>(c_.guard_alphas.size());  // the rung past the alphas
  d_.guard_raised_now = false;
  for (;;) {
    stats.guard_seconds += seconds_since(tg);
    const long failures = stats.cg_failures;
    if (d_.guard_rung == backward_euler) {
      linear_step(s, dt, 1.0, 0.0, dt, stats);
    } else {
      bdf2_step(s, dt, c_.guard_alphas[d_.guard_rung], stats);
    }
    tg = Clock::now();
    if (!puts_energy_in(s)) break;
    stats.cg_failures = failures;  // the attempt is discarded
    s = d_.guard_start;
    d_.pulling = pulling;
    d_.stuck = stuck;
    if (d_.guard_rung == backward_euler) {
      // Backward Euler still puts energy in (an element turning fast): its halves, each
      // checked and halved again the same way (kGuardMaxSplits times at most).
      ++stats.guard_split_steps;
      stats.guard_seconds += seconds_since(tg);
      int parts = 0;
      backward_euler_parts(s, 0.5 * dt, stats, 1, parts);
      backward_euler_parts(s, 0.5 * dt, stats, 1, parts);
      accept_guarded(1.0, stats, parts);
      if (d_.guard_raised_now) ++stats.guard_raised_steps;
      return;
    }
    ++d_.guard_rung;
    d_.guard_calm_steps = 0;
    ++stats.guard_redone_steps;
  }
  stats.guard_seconds += seconds_since(tg);
  accept_guarded(d_.guard_rung == backward_euler ? 1.0 : c_.guard_alphas[d_.guard_rung], stats);
  if (d_.guard_raised_now) ++stats.guard_raised_steps;
}

void Integrator::backward_euler_parts(State& s, double dt, StepStatistics& stats, int splits, int& parts) {
  auto tg = Clock::now();
  d_.guard_start = s;
  const std::vector<char> pulling = d_.pulling, stuck = d_.stuck;
  stats.guard_seconds += seconds_since(tg);
  const long failures = stats.cg_failures;
  linear_step(s, dt, 1.0, 0.0, dt, stats);
  tg = Clock::now();
  if (splits >= kGuardMaxSplits || !puts_energy_in(s)) {
    ++parts;
    stats.guard_seconds += seconds_since(tg);
    return;
  }
  stats.cg_failures = failures;  // the attempt is discarded
  s = d_.guard_start;
  d_.pulling = pulling;
  d_.stuck = stuck;
  ++stats.guard_split_steps;
  stats.guard_seconds += seconds_since(tg);
  backward_euler_parts(s, 0.5 * dt, stats, splits + 1, parts);
  backward_euler_parts(s, 0.5 * dt, stats, splits + 1, parts);
}

void Integrator::linear_step(State& s, double dt, double alpha, double beta, double dt_b,
                             StepStatistics& stats) {
  const auto t0 = Clock::now();
  if (!d_.handlers.empty()) {
    d_.start_kinetic = kinetic_energy(s.v);
    d_.start_viscous = s.viscous_dissipated;
    d_.start_contact_work = s.contact_work;
  }
  system_.begin_step(s.x, s.v, dt);
  const BlockPattern& P = system_.pattern();
  const int n = system_.num_nodes();
  const VecX& m = system_.node_mass();
  // w = beta dx_p + dt_b v, so that the right-hand side is
  //   beta M dv_p + dt_b f + alpha dt_b K w
  // and the matrix M - alpha dt_b D - alpha^2 dt_b^2 K (docs/method.md 1-2).
  d_.w = dt_b * s.v;
  if (beta != 0.0) d_.w += beta * s.dx_prev;
  d_.step.ck = alpha * alpha * dt_b * dt_b;
  d_.step.cd = alpha * dt_b;
  system_.assemble_step(s.x, s.v, d_.w, d_.step);
  d_.rhs = dt_b * d_.step.force;
  if (beta != 0.0) d_.rhs += beta * c_.mass3.cwiseProduct(s.dv_prev);
  if (alpha > 0.0) d_.rhs += alpha * dt_b * d_.step.stiffness_times_w;
  for (int i = 0; i < n; ++i) d_.step.matrix.block[P.diagonal_slot(i)].diagonal().array() += m[i];
  stats.assembly_seconds += seconds_since(t0);

  const auto t1 = Clock::now();
  // The contacts' detection and response within the solve's passes count as theirs, not the
  // solve's: the split of a step's time adds up to it.
  const double contact_seconds_before = stats.detection_seconds + stats.response_seconds;
  // Warm start: the combination of the last steps' solutions whose right-hand sides best fit
  // this one (SolutionHistory), else the previous change in velocity.
  if (alpha != d_.history_alpha || beta != d_.history_beta || dt_b != d_.history_dt_b ||
      s.t != d_.history_t) {
    d_.history.clear();
    d_.history_alpha = alpha;
    d_.history_beta = beta;
    d_.history_dt_b = dt_b;
  }
  if (!d_.history.guess(d_.rhs, d_.dv)) {
    if (s.dv_prev.size() == 3 * n) d_.dv = s.dv_prev; else d_.dv = VecX::Zero(3 * n);
  }
  // Contacts (semi-implicit steps that depend on dv): detected at the step's start, held by
  // the solve as constraints.
  d_.contacts.clear();
  if (!d_.handlers.empty()) {
    const auto td = Clock::now();
    for (ContactHandler* h : d_.handlers) h->detect(s.x, s.v, s.t, dt, d_.contacts);
    if (d_.pulling.size() != static_cast<size_t>(n)) d_.pulling.assign(n, 0);
    size_t kept = 0;
    for (const NodeContact& c : d_.contacts) {
      if (d_.pulling[c.node] && !c.penetrating && !c.kinematic) {
        ++stats.released_contacts;
        continue;
      }
      d_.contacts[kept++] = c;
    }
    d_.contacts.resize(kept);
    std::fill(d_.pulling.begin(), d_.pulling.end(), 0);
    stats.detection_seconds += seconds_since(td);
  }
  if (alpha == 0.0) d_.contacts.clear();  // dx does not depend on dv: the fail-safe alone acts
  if (!d_.handlers.empty()) {
    // A node that ended the last step stuck to a surface starts this one stuck.
    if (d_.stuck.size() != static_cast<size_t>(n)) d_.stuck.assign(n, 0);
    d_.contact_stuck.resize(d_.contacts.size());
    for (size_t k = 0; k < d_.contacts.size(); ++k)
      d_.contact_stuck[k] = d_.contacts[k].kinematic || (d_.stuck[d_.contacts[k].node] && d_.contacts[k].friction > 0);
    std::fill(d_.stuck.begin(), d_.stuck.end(), 0);
  }

  const PcgSettings ps = pcg_settings();
  if (c_.preconditioner == Preconditioner::kMultigrid && !d_.pcg.multigrid.matches(P, system_.fixed(), ps.multigrid)) {
    // Built here rather than inside the solve, to keep the matrix it was built from.
    d_.pcg.multigrid.setup(d_.step.matrix, system_.fixed(), ps.multigrid);
    d_.multigrid_setup_blocks = d_.step.matrix.block;
  }
  // With contacts, an active set: the solve holds the detected contacts; nodes it would leave
  // inside a collider's thickness at the step's end join them and the step is solved again
  // (a few times at most; the handler's fail-safe catches what remains).
  if (!d_.contacts.empty() || (!d_.handlers.empty() && alpha > 0.0)) d_.rhs_unconstrained = d_.rhs;
  PcgResult r;
  const bool bounded = c_.settings.contact_solve == ContactSolve::kBounds;
  bool bounded_last = false;
  for (int pass = 0;; ++pass) {
    bounded_last = bounded && !d_.contacts.empty();
    if (bounded_last) {
      r = bounded_pass(s, dt, alpha, beta, dt_b, stats);
    } else {
      if (!d_.contacts.empty()) {
        const auto tr = Clock::now();
        constrain(s, dt, alpha, beta, dt_b);
        stats.response_seconds += seconds_since(tr);
      }
      r = solve_pcg(d_.step.matrix, d_.rhs, system_.fixed(), ps, d_.dv, d_.pcg);
      stats.cg_iterations += r.iterations;
      ++stats.cg_solves;
      if (!r.converged) ++stats.cg_failures;
      if (d_.contacts.empty() && pass == 0) {
        if (r.converged) d_.history.record(d_.rhs, system_.fixed(), d_.dv);
      }
      if (!d_.contacts.empty()) {
        const auto tr = Clock::now();
        unconstrain(dt, dt_b);
        d_.rhs = d_.rhs_unconstrained;
        stats.response_seconds += seconds_since(tr);
      }
    }
    if (d_.handlers.empty() || alpha == 0.0 || pass + 1 >= kMaxContactPasses) break;
    // Contacts that pull are let go (a node stays held when it was let go before in this step
    // and came back, or starts inside the collider); nodes that would end inside join.
    const auto td = Clock::now();
    if (pass == 0) {
      d_.released_now.assign(n, 0);
      d_.keep_held.assign(n, 0);
    }
    bool changed = false;
    size_t kept = 0;
    const VecX& mass = system_.node_mass();
    for (size_t k = 0; k < d_.contacts.size(); ++k) {
      NodeContact& c = d_.contacts[k];
      const Vec3& J = d_.contact_impulse[k];
      const double normal_impulse = c.normal.dot(J);
      // A stuck contact whose impulse left the friction cone slides: solved again with the
      // active set; with bounds, it slides from here on without a second solve (its node
      // moved with the surface over this step, and leaves it at the sliding velocity
      // Coulomb's limit gives: contact_velocities).
      if (d_.contact_stuck[k] == 1 && !c.kinematic &&
          (J - c.normal * normal_impulse - c.normal2 * c.normal2.dot(J)).norm() >
              c.friction * std::max(normal_impulse, 0.0)) {
        d_.contact_stuck[k] = bounded ? kSlipped : 0;
        if (!bounded) changed = true;
      }
      // A second direction that pulls is let go alone.
      if (c.has_normal2() && c.normal2.dot(J) < -kReleaseSpeed * mass[c.node] && !d_.keep_held[c.node]) {
        c.normal2 = Vec3::Zero();
        changed = true;
      }
      if (bounded && d_.contact_stuck[k] == 1 && normal_impulse < -kReleaseSpeed * mass[c.node] && !c.penetrating &&
          !c.kinematic) {
        // Held stuck and pulling, with bounds: let go after this step (contact_velocities takes
        // the pull back), not solved again.
        d_.contact_stuck[k] = kSlipped;
      }
      if (normal_impulse < -kReleaseSpeed * mass[c.node] && !c.penetrating && !c.kinematic && !d_.keep_held[c.node] &&
          d_.contact_stuck[k] != kSlipped) {
        d_.released_now[c.node] = 1;
        ++stats.released_contacts;
        changed = true;
        continue;
      }
      d_.contact_stuck[kept] = d_.contact_stuck[k];
      d_.contacts[kept++] = c;
    }
    d_.contacts.resize(kept);
    d_.contact_stuck.resize(kept);
    const size_t before = join_end_contacts(s, dt, alpha, beta, dt_b);
    d_.contact_stuck.resize(d_.contacts.size(), 0);  // those that join slide
    for (size_t k = before; k < d_.contacts.size(); ++k)
      if (d_.released_now[d_.contacts[k].node]) d_.keep_held[d_.contacts[k].node] = 1;
    stats.detection_seconds += seconds_since(td);
    if (d_.contacts.size() != before) changed = true;
    if (!changed) break;
    ++stats.contact_passes;
  }
  if (bounded_last) release_inactive_bounds(stats);
  if (!d_.contacts.empty()) {
    stats.contacts += static_cast<long>(d_.contacts.size());
    ++stats.contact_solves;
    stats.max_contacts = std::max(stats.max_contacts, static_cast<long>(d_.contacts.size()));
    if (r.converged) d_.history.record(d_.rhs, system_.fixed(), d_.dv);
  }
  stats.solve_seconds += seconds_since(t1) - (stats.detection_seconds + stats.response_seconds - contact_seconds_before);
  const int newton_iterations =
      newton_limit() > 0 && alpha > 0.0 ? newton_iterate(s, dt, alpha, beta, dt_b, stats) : 0;
  if (!d_.handlers.empty()) d_.x_start = s.x;

  // dx = beta dx_p + dt_b (v + alpha dv), built in dx_prev's storage (no allocation per step);
  // d_.mean_velocity holds the mean velocity dx/dt.
  if (beta != 0.0) {
    s.dx_prev = beta * s.dx_prev + dt_b * (s.v + alpha * d_.dv);
  } else {
    s.dx_prev = dt_b * (s.v + alpha * d_.dv);
  }
  // Viscous work over the step, at the start's positions with the step's mean velocity
  // dx/dt (docs/method.md 6); for forward Euler the start's velocity. A step Newton iterated
  // evaluated its forces at x_a = x + alpha dx: its viscous force does its work there.
  if (newton_iterations > 0) {
    d_.mean_velocity = s.dx_prev / dt;
    d_.x_forces = s.x + alpha * s.dx_prev;
    s.viscous_dissipated -= dt * system_.viscous_power(d_.x_forces, d_.mean_velocity);
  } else if (alpha > 0.0) {
    d_.mean_velocity = s.dx_prev / dt;
    s.viscous_dissipated -= dt * system_.step_viscous_power(s.x, d_.mean_velocity, d_.step);
  } else {
    s.viscous_dissipated -= dt * d_.step.viscous_power;
  }
  s.x += s.dx_prev;
  s.v += d_.dv;
  s.dv_prev = d_.dv;
  s.has_history = true;
  if (!d_.handlers.empty()) {
    const auto tr = Clock::now();
    contact_velocities(s, dt, dt_b);
    stats.response_seconds += seconds_since(tr);
    finish_contacts(s, s.t, dt, stats);
  }
  s.t += dt;
  d_.history_t = s.t;
}

double Integrator::newton_residual(const State& s, double alpha, double beta, double dt_b, const VecX& dv,
                                   VecX& r) {
  d_.newton_v = s.v + alpha * dv;
  d_.newton_x = s.x + (alpha * dt_b) * d_.newton_v;
  if (beta != 0.0) d_.newton_x += (alpha * beta) * s.dx_prev;
  system_.evaluate(d_.newton_x, d_.newton_v, false, d_.eval);
  r = dt_b * d_.eval.force - c_.mass3.cwiseProduct(dv);
  if (beta != 0.0) r += beta * c_.mass3.cwiseProduct(s.dv_prev);
  const auto& fixed = system_.fixed();
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) r.segment<3>(3 * i).setZero();
  if (d_.contacts.empty()) return std::sqrt(r.cwiseAbs2().cwiseQuotient(c_.mass3).sum());
  // At a contact only the free directions' residual counts: the held ones carry the
  // constraint's force.
  const VecX& m = system_.node_mass();
  double sum = 0;
  for (int i = 0, n = system_.num_nodes(); i < n; ++i) {
    const int k = d_.contact_slot[i];
    const Vec3 ri = k < 0 ? Vec3(node(r, i)) : Vec3(contact_filter(k) * node(r, i));
    sum += ri.squaredNorm() / m[i];
  }
  return std::sqrt(sum);
}

// Newton's method on the step's equations before linearisation (docs/method.md 1-2): the step
// evaluates the derivative at Q + alpha dQ,
//   g(dv) = M dv - beta M dv_p - dt_b f(x_a, v_a) = 0,
//   x_a = x + alpha (beta dx_p + dt_b (v + alpha dv)),  v_a = v + alpha dv,
// whose Jacobian M - alpha dt_b D - alpha^2 dt_b^2 K at (x_a, v_a) is the step matrix assembled
// there. The linearised step (K, D and f at the step's start, f(x_a) extrapolated with K) is
// the first iterate; on a stiffening curve it can stretch an element far past where the
// start's tangent holds, and the next step's force then throws the cloth apart. Each iteration
// solves A delta = r at the current iterate and takes the largest of delta, delta/2, ...
// (kNewtonMaxHalvings halvings) that lowers |M^-1/2 r| (Armijo's rule); the step keeps the
// last iterate when none does. Adaptive damping's viscosities stay those of the step's start.
int Integrator::newton_iterate(const State& s, double dt, double alpha, double beta, double dt_b,
                               StepStatistics& stats) {
  const auto t0 = Clock::now();
  const VecX& m = system_.node_mass();
  const BlockPattern& P = system_.pattern();
  const int n = system_.num_nodes();
  auto index_contacts = [&] {
    d_.contact_slot.assign(n, -1);
    for (size_t k = 0; k < d_.contacts.size(); ++k) d_.contact_slot[d_.contacts[k].node] = static_cast<int>(k);
  };
  if (!d_.contacts.empty()) index_contacts();
  const double rhs_norm = std::sqrt(d_.rhs.cwiseAbs2().cwiseQuotient(c_.mass3).sum());
  double residual = newton_residual(s, alpha, beta, dt_b, d_.dv, d_.newton_r);
  auto converged = [&] {
    const double dv_norm = std::sqrt(c_.mass3.dot(d_.dv.cwiseAbs2()));
    return residual <= c_.settings.newton_tolerance * std::max(dv_norm, rhs_norm);
  };
  int taken = 0, moved = 0;
  bool stuck = false;
  for (int round = 0;; ++round) {
    // A round after nodes joined the contacts gets at least one iteration.
    const int limit = round == 0 ? newton_limit() : std::max(newton_limit(), taken + 1);
    const int taken_before = taken;
    while (std::isfinite(residual) && !converged() && taken < limit) {
      d_.newton_step.ck = alpha * alpha * dt_b * dt_b;
      d_.newton_step.cd = alpha * dt_b;
      d_.newton_w.setZero(3 * n);
      system_.assemble_step(d_.newton_x, d_.newton_v, d_.newton_w, d_.newton_step);
      for (int i = 0; i < n; ++i) d_.newton_step.matrix.block[P.diagonal_slot(i)].diagonal().array() += m[i];
      // With contacts, the correction keeps dv's held components (the prescribed ones): the
      // matrix and the residual are filtered as the linearised step's are (constrain).
      const VecX* rhs = &d_.newton_r;
      if (!d_.contacts.empty()) {
        filter_matrix(d_.newton_step.matrix, [](int) {});
        d_.newton_rhs = d_.newton_r;
        for (size_t k = 0; k < d_.contacts.size(); ++k) {
          const int i = d_.contacts[k].node;
          node(d_.newton_rhs, i) = contact_filter(k) * node(d_.newton_rhs, i);
        }
        rhs = &d_.newton_rhs;
      }
      d_.newton_delta.setZero(3 * n);
      const PcgResult r =
          solve_pcg(d_.newton_step.matrix, *rhs, system_.fixed(), pcg_settings(), d_.newton_delta, d_.pcg);
      stats.cg_iterations += r.iterations;
      ++stats.cg_solves;
      if (!r.converged) ++stats.cg_failures;
      ++taken;
      double fraction = 1.0;
      bool accepted = false;
      for (int halving = 0; halving <= kNewtonMaxHalvings; ++halving) {
        d_.newton_dv_trial = d_.dv + fraction * d_.newton_delta;
        const double trial = newton_residual(s, alpha, beta, dt_b, d_.newton_dv_trial, d_.newton_r_trial);
        if (trial <= (1.0 - 1e-4 * fraction) * residual) {
          d_.dv.swap(d_.newton_dv_trial);
          d_.newton_r.swap(d_.newton_r_trial);
          residual = trial;
          accepted = true;
          ++moved;
          break;
        }
        fraction *= 0.5;
        ++stats.newton_halvings;
      }
      if (!accepted) {
        stuck = true;
        break;
      }
    }
    if (d_.handlers.empty() || stuck || taken == taken_before || round >= kNewtonContactRounds) break;
    // The iterations moved the free nodes: those that would now end inside a collider's
    // thickness join the contacts, their held components prescribed, and the iterations go on.
    const auto td = Clock::now();
    const size_t before = join_end_contacts(s, dt, alpha, beta, dt_b);
    stats.detection_seconds += seconds_since(td);
    if (d_.contacts.size() == before) break;
    d_.contact_stuck.resize(d_.contacts.size(), 0);
    d_.contact_dv.resize(d_.contacts.size());
    for (size_t k = before; k < d_.contacts.size(); ++k) {
      const int i = d_.contacts[k].node;
      d_.contact_dv[k] = prescribed_dv(s, k, dt, alpha, beta, dt_b);
      node(d_.dv, i) = contact_filter(k) * node(d_.dv, i) + d_.contact_dv[k];
    }
    index_contacts();
    residual = newton_residual(s, alpha, beta, dt_b, d_.dv, d_.newton_r);
  }
  if (taken > 0) {
    ++stats.newton_steps;
    stats.newton_iterations += taken;
    // The constraints' impulses where the iterations ended: the held components of the
    // residual, -(A dv - b) there (unconstrain).
    d_.contact_impulse.resize(d_.contacts.size());
    for (size_t k = 0; k < d_.contacts.size(); ++k)
      d_.contact_impulse[k] = -(dt / dt_b) * node(d_.newton_r, d_.contacts[k].node);
  }
  if (stuck || !converged()) ++stats.newton_unconverged;
  stats.newton_seconds += seconds_since(t0);
  return moved;
}

// The contact constraints (Baraff and Witkin's filters, docs/collisions.md). A sliding contact
// at node i with normal n prescribes dv_i . n and leaves dv_i's tangential part free,
// S_i = I - n n^T (held against a second surface too, with n2 orthogonal to n:
// S_i = I - n n^T - n2 n2^T, free only along n x n2); a sticking one prescribes all of dv_i
// (S_i = 0), the node moving with the surface. Writing dv = y + z with y_i in S_i's range and z_i the prescribed part, the solve's
// equations are the free directions' ones, S (A (y + z) - b) = 0, that is
//   (S A S + c (I - S)) y = S (b - A z)
// where the c (I - S) term (c the node's mean diagonal stiffness) only keeps the matrix positive
// definite: its (I - S) rows give (I - S) y = 0. The matrix keeps A's pattern and is symmetric
// positive definite, so every preconditioner solves it unchanged; the changed blocks are put
// back after the solve. z is chosen so that the step's displacement beta dx_p + dt_b (v +
// alpha dv) has the prescribed part.
Mat3 Integrator::contact_filter(size_t k) const {
  const NodeContact& c = d_.contacts[k];
  if (d_.contact_stuck[k]) return Mat3::Zero();
  const Vec3& n = c.normal;
  return Mat3::Identity() - n * n.transpose() - c.normal2 * c.normal2.transpose();
}

size_t Integrator::join_end_contacts(const State& s, double dt, double alpha, double beta, double dt_b) {
  d_.x_end = s.x + dt_b * (s.v + alpha * d_.dv);
  if (beta != 0.0) d_.x_end += beta * s.dx_prev;
  d_.held.assign(system_.num_nodes(), 0);
  for (const NodeContact& c : d_.contacts) d_.held[c.node] = 1;
  const size_t before = d_.contacts.size();
  for (ContactHandler* h : d_.handlers) h->detect_end(s.x, d_.x_end, s.t, dt, d_.held, d_.contacts);
  return before;
}

Vec3 Integrator::prescribed_dv(const State& s, size_t k, double dt, double alpha, double beta, double dt_b) const {
  const NodeContact& c = d_.contacts[k];
  const int i = c.node;
  // The prescribed displacement: along the normal, and when stuck the surface's tangential one.
  Vec3 target = c.normal * c.normal_displacement + c.normal2 * c.normal_displacement2;
  if (c.kinematic) {
    target = c.displacement;
  } else if (d_.contact_stuck[k]) {
    target += dt * (c.surface_velocity - c.normal * c.normal.dot(c.surface_velocity) -
                    c.normal2 * c.normal2.dot(c.surface_velocity));
  }
  if (beta != 0.0) target -= beta * node(s.dx_prev, i);
  return (Mat3::Identity() - contact_filter(k)) * ((target / dt_b - node(s.v, i)) / alpha);
}

void Integrator::constrain(const State& s, double dt, double alpha, double beta, double dt_b) {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  std::vector<Mat3>& blocks = d_.step.matrix.block;
  const size_t count = d_.contacts.size();
  d_.contact_dv.resize(count);
  d_.contact_rhs.resize(count);
  if (d_.slot_saved.size() != blocks.size()) d_.slot_saved.assign(blocks.size(), 0);
  d_.saved_blocks.clear();
  auto save = [&](int slot) {
    if (d_.slot_saved[slot]) return;
    d_.slot_saved[slot] = 1;
    d_.saved_blocks.emplace_back(slot, blocks[slot]);
  };
  // z, and b - A z with the original blocks.
  for (size_t k = 0; k < count; ++k) {
    d_.contact_dv[k] = prescribed_dv(s, k, dt, alpha, beta, dt_b);
    d_.contact_rhs[k] = node(d_.rhs, d_.contacts[k].node);
  }
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    const Vec3& z = d_.contact_dv[k];
    for (int e = row_start[i]; e < row_start[i + 1]; ++e)
      node(d_.rhs, column[e]) -= blocks[e].transpose() * z;  // A_ji = A_ij^T
  }
  // S (b - A z) and the warm start's y in the free directions.
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    const Mat3 S = contact_filter(k);
    node(d_.rhs, i) = S * node(d_.rhs, i);
    node(d_.dv, i) = S * node(d_.dv, i);
  }
  filter_matrix(d_.step.matrix, save);
}

template <class Save>
void Integrator::filter_matrix(BlockMatrix& matrix, const Save& save) const {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  std::vector<Mat3>& blocks = matrix.block;
  const size_t count = d_.contacts.size();
  // S_i A_ij and A_ji S_i for every contact i (both: S_i A_ij S_j), the diagonal blocks last.
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    const Mat3 S = contact_filter(k);
    for (int e = row_start[i]; e < row_start[i + 1]; ++e) {
      const int j = column[e];
      if (j == i) continue;
      const int et = P.slot(j, i);
      save(e);
      save(et);
      blocks[e] = S * blocks[e];
      blocks[et] = blocks[et] * S;
    }
  }
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    const Mat3 S = contact_filter(k);
    const int d = P.diagonal_slot(i);
    save(d);
    Mat3& a = blocks[d];
    const double c = a.trace() / 3;
    a = S * a * S + c * (Mat3::Identity() - S);
  }
  matrix.constants_changed();
}

void Integrator::unconstrain(double dt, double dt_b) {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  std::vector<Mat3>& blocks = d_.step.matrix.block;
  for (const auto& [slot, value] : d_.saved_blocks) {
    blocks[slot] = value;
    d_.slot_saved[slot] = 0;
  }
  d_.saved_blocks.clear();
  d_.step.matrix.constants_changed();
  const size_t count = d_.contacts.size();
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    node(d_.dv, i) = contact_filter(k) * node(d_.dv, i) + d_.contact_dv[k];
  }
  contact_impulses(dt, dt_b);
}

void Integrator::contact_impulses(double dt, double dt_b) {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  const std::vector<Mat3>& blocks = d_.step.matrix.block;
  const size_t count = d_.contacts.size();
  d_.contact_impulse.resize(count);
  // The constraint's impulse: what A dv - b leaves at the node, dt_b times the contact force.
  for (size_t k = 0; k < count; ++k) {
    const int i = d_.contacts[k].node;
    Vec3 a_dv = Vec3::Zero();
    for (int e = row_start[i]; e < row_start[i + 1]; ++e) a_dv += blocks[e] * node(d_.dv, column[e]);
    d_.contact_impulse[k] = (dt / dt_b) * (a_dv - d_.contact_rhs[k]);
  }
}

// Contacts as bounds (docs/collisions.md, "Contacts as bounds"): a sliding contact's node may
// not end nearer the surface than its prescribed displacement puts it, n . dv_i >= n . z_i with
// z_i prescribed_dv's part along the normal (and likewise along a second normal); a stuck or
// kinematic contact's node is held at its whole prescribed dv. The bounded solve
// (linalg/mprgp.hpp) finds which bounds hold at the step's answer: those that would pull are
// free, so no contact needs a second solve to be let go.
PcgResult Integrator::bounded_pass(const State& s, double dt, double alpha, double beta, double dt_b,
                                   StepStatistics& stats) {
  const auto tr = Clock::now();
  const size_t count = d_.contacts.size();
  d_.bound_held = system_.fixed();
  for (size_t i = 0; i < d_.bound_held.size(); ++i)
    if (d_.bound_held[i]) node(d_.dv, static_cast<int>(i)).setZero();
  d_.bounds.clear();
  d_.bound_contact.clear();
  d_.contact_rhs.resize(count);
  for (size_t k = 0; k < count; ++k) {
    const NodeContact& c = d_.contacts[k];
    if (d_.contact_stuck[k] == kSlipped) d_.contact_stuck[k] = 0;  // solved again: it slides
    const Vec3 z = prescribed_dv(s, k, dt, alpha, beta, dt_b);
    d_.contact_rhs[k] = node(d_.rhs, c.node);
    if (c.kinematic || d_.contact_stuck[k] == 1) {
      d_.bound_held[c.node] = 1;
      node(d_.dv, c.node) = z;
      continue;
    }
    d_.bounds.push_back({c.node, c.normal, c.normal.dot(z)});
    d_.bound_contact.push_back(static_cast<int>(k));
    if (c.has_normal2()) {
      d_.bounds.push_back({c.node, c.normal2, c.normal2.dot(z)});
      d_.bound_contact.push_back(static_cast<int>(k));
    }
  }
  stats.response_seconds += seconds_since(tr);
  BoundedSolveSettings settings;
  settings.relative_tolerance = c_.settings.cg_tolerance;
  settings.max_iterations = c_.settings.cg_max_iterations;
  const BoundedSolveResult b = solve_bounded(d_.step.matrix, d_.rhs, d_.bound_held, d_.bounds, settings, d_.dv,
                                             d_.bounded, d_.bound_active);
  stats.cg_iterations += b.iterations;
  ++stats.cg_solves;
  if (!b.converged) ++stats.cg_failures;
  const auto tr2 = Clock::now();
  contact_impulses(dt, dt_b);
  stats.response_seconds += seconds_since(tr2);
  PcgResult r;
  r.iterations = b.iterations;
  r.relative_residual = b.relative_residual;
  r.converged = b.converged;
  return r;
}

void Integrator::release_inactive_bounds(StepStatistics& stats) {
  // Each contact's bounds were pushed in order: its normal's, then its second normal's.
  const size_t count = d_.contacts.size();
  d_.bound_free.assign(count, 0);  // per contact: bit 1 the normal's bound free, bit 2 the second's
  for (size_t j = 0; j < d_.bounds.size(); ++j) {
    const int k = d_.bound_contact[j];
    const bool second = j > 0 && d_.bound_contact[j - 1] == k;
    if (!d_.bound_active[j]) d_.bound_free[k] |= second ? 2 : 1;
  }
  size_t kept = 0;
  for (size_t k = 0; k < count; ++k) {
    NodeContact& c = d_.contacts[k];
    const char free = d_.bound_free[k];
    const bool first_free = free & 1, second_free = (free & 2) || !c.has_normal2();
    if (first_free && second_free) {
      ++stats.released_contacts;
      continue;
    }
    if (first_free) {
      c.normal = c.normal2;
      c.normal_displacement = c.normal_displacement2;
    }
    if (first_free || second_free) {
      c.normal2 = Vec3::Zero();
      c.normal_displacement2 = 0;
    }
    d_.contact_stuck[kept] = d_.contact_stuck[k];
    d_.contact_impulse[kept] = d_.contact_impulse[k];
    d_.contact_rhs[kept] = d_.contact_rhs[k];
    d_.contacts[kept++] = c;
  }
  d_.contacts.resize(kept);
  d_.contact_stuck.resize(kept);
  d_.contact_impulse.resize(kept);
  d_.contact_rhs.resize(kept);
}

void Integrator::contact_velocities(State& s, double dt, double dt_b) {
  const VecX& m = system_.node_mass();
  for (size_t k = 0; k < d_.contacts.size(); ++k) {
    const NodeContact& c = d_.contacts[k];
    const int i = c.node;
    const Vec3& J = d_.contact_impulse[k];
    const double normal_impulse = c.normal.dot(J);
    if (normal_impulse < -kReleaseSpeed * m[i] && !c.kinematic) d_.pulling[i] = 1;
    // The work of the constraint's impulse over the step's displacement.
    s.contact_work += J.dot(node(s.x, i) - node(d_.x_start, i)) / dt;
    const Vec3 v_old = node(s.v, i);
    Vec3 v_new;
    if (c.kinematic) {
      v_new = c.surface_velocity;
    } else if (d_.contact_stuck[k] == kSlipped) {
      // Held stuck by the solve, its impulse outside the friction cone (contacts as bounds):
      // the tangential impulse beyond Coulomb's limit is taken back, and the node slides from
      // the next step on.
      // What of the impulse lies outside the friction cone (a pull along the normal, the
      // tangential part beyond friction times the push) is taken back.
      const Vec3 Jt = J - c.normal * normal_impulse - c.normal2 * c.normal2.dot(J);
      const double push = std::max(normal_impulse, 0.0), limit = c.friction * push, jt = Jt.norm();
      const Vec3 kept = c.normal * push + c.normal2 * c.normal2.dot(J) + (jt > limit ? limit / jt : 1.0) * Jt;
      v_new = c.surface_velocity - ((dt_b / dt) / m[i]) * (J - kept);
      d_.stuck[i] = 0;
    } else if (d_.contact_stuck[k]) {
      // Stuck: the node leaves the step moving with the surface, and stays stuck.
      v_new = c.surface_velocity;
      d_.stuck[i] = 1;
    } else {
      // Sliding: Coulomb friction takes up to friction * impulse / m off the sliding speed (a
      // change of velocity after the step, which only takes kinetic energy out); a node it
      // stops is stuck from the next step on. Along the normal the contact is inelastic: the
      // node leaves the step moving with the surface.
      const Vec3 u = v_old - c.surface_velocity;
      const Vec3 ut = u - c.normal * c.normal.dot(u) - c.normal2 * c.normal2.dot(u);
      const double slide = ut.norm();
      // (For BDF-2, whose step applies a force over dt_b and repeats the last change of
      // velocity by beta, the change is dt_b / dt of the impulse's: the sliding then slows by
      // exactly friction * impulse / m per step, as with the other methods.)
      const double stop = (dt_b / dt) * c.friction * std::max(normal_impulse, 0.0) / m[i];
      const bool stops = c.friction > 0 && slide <= stop;
      // (Not sliding at all, ut is zero and so is what friction takes off it.)
      v_new = c.surface_velocity + (stops || !(slide > 0) ? 0.0 : 1 - stop / slide) * ut;
      d_.stuck[i] = stops ? 1 : 0;
    }
    node(s.v, i) = v_new;
    // BDF-2's history as if the node had moved at its new velocity: the change of velocity as
    // taken, the displacement changed by dt times the correction (a node stopped by friction
    // is then at rest for the next step, not carrying the step's sliding).
    node(s.dv_prev, i) += v_new - v_old;
    node(s.dx_prev, i) += dt * (v_new - v_old);
    if (!c.kinematic) {
      // Along the normal the contact is an impact, not a force: the history must not carry it
      // on (BDF-2 repeats a third of the last step's displacement and change of velocity, and
      // a cloth landing on the floor rebounded from its own impact). The displacement is the
      // one at the node's new velocity, without the thickness restored; the change of velocity
      // keeps no approach the contact stopped.
      for (const Vec3* held : {&c.normal, &c.normal2}) {
        const Vec3& n = *held;
        node(s.dx_prev, i) += (dt * v_new.dot(n) - node(s.dx_prev, i).dot(n)) * n;
        const double change = node(s.dv_prev, i).dot(n);
        if (change > 0) node(s.dv_prev, i) -= change * n;
      }
    }
    s.contact_work += 0.5 * m[i] * (v_new.squaredNorm() - v_old.squaredNorm());
  }
}

void Integrator::finish_contacts(State& s, double t0, double dt, StepStatistics& stats) {
  const auto tr = Clock::now();
  d_.v_before_fail_safe = s.v;
  // An unguarded semi-implicit solve that held contacts and put energy in (kSolveGainLimit) is
  // taken again as two halves, whatever the fail-safes make of it. (The guarded steps weigh the
  // whole step's gain; without contacts, or without an energy scale to weigh it by, the step is
  // the method's own.)
  bool overshot = false;
  const bool held = std::any_of(d_.contacts.begin(), d_.contacts.end(), [](const NodeContact& c) { return !c.kinematic; });
  if (held && d_.energy_scale > 0 && c_.settings.halve_overshooting_solves && !c_.settings.guard &&
      (c_.settings.method == Method::AlphaFamily || c_.settings.method == Method::Bdf2) && c_.settings.alpha > 0.0) {
    double elastic, gravity;
    potential_energy(s.x, elastic, gravity);
    const double start = d_.start_kinetic + d_.step.elastic_energy + d_.step.gravity_energy;
    const double gain = kinetic_energy(s.v) + elastic + gravity - start + (s.viscous_dissipated - d_.start_viscous) -
                        (s.contact_work - d_.start_contact_work);
    const double scale = std::max(d_.energy_scale, d_.start_kinetic + d_.step.elastic_energy);
    overshot = !(gain <= kSolveGainLimit * scale);
  }
  // The fail-safes first, then the handlers that prescribe motions (clamps), which have the
  // last word on their vertices. Each group's work is the whole change of mechanical energy it
  // made: besides the kinetic energy of its changes of velocity (report.work), moving a vertex
  // changes the elastic and gravitational energy, which the balance would otherwise book as
  // the integrator's. The fail-safes' share is kept apart (State::fail_safe_work).
  ContactReport all;
  for (bool prescribed : {false, true}) {
    ContactReport report;
    d_.x_before_fail_safe = s.x;
    VecX& v_before = d_.v_before_group;
    v_before = s.v;
    std::vector<ContactHandler*>& group = d_.handler_group;
    group.clear();
    for (ContactHandler* h : d_.handlers)
      if (h->prescribes_motion() == prescribed) group.push_back(h);
    for (size_t k = 0; k < group.size(); ++k) {
      if (k == 1) d_.x_round = s.x;
      group[k]->finish_step(d_.x_start, s.x, s.v, t0, dt, report);
    }
    // One handler's correction can undo another's (the cloth's impulses pushing a layer the
    // colliders put back into a collider): the first handler looks again at the nodes the
    // others moved, and while it moves some, the others correct after it again.
    for (int round = 1; group.size() > 1 && round <= kFailSafeRounds; ++round) {
      if (s.x == d_.x_round) break;
      report.round = round;
      report.left = &d_.x_round;
      const long moves = report.fail_safe_moves;
      group[0]->finish_step(d_.x_start, s.x, s.v, t0, dt, report);
      if (report.fail_safe_moves == moves) break;
      if (round == kFailSafeRounds) report.ok = false;
      d_.x_round = s.x;
      for (size_t k = 1; k < group.size(); ++k) group[k]->finish_step(d_.x_start, s.x, s.v, t0, dt, report);
    }
    report.round = 0;
    report.left = nullptr;
    if (report.fail_safe_moves > 0) {
      double elastic, gravity;
      potential_energy(d_.x_before_fail_safe, elastic, gravity);
      const double before = kinetic_energy(v_before) + elastic + gravity;
      potential_energy(s.x, elastic, gravity);
      report.work = kinetic_energy(s.v) + elastic + gravity - before;
    }
    s.contact_work += report.work;
    if (!prescribed) s.fail_safe_work += report.work;
    all.fail_safe_moves += report.fail_safe_moves;
    all.ok = all.ok && report.ok;
  }
  if (all.fail_safe_moves > 0 && s.dx_prev.size() == s.v.size()) {
    // BDF-2's last displacement as if the nodes had moved at their corrected velocities, or it
    // would repeat a third of an approach the fail-safe stopped; its last change of velocity
    // is left alone, or it would repeat a third of the fail-safe's impulse.
    d_.v_before_fail_safe = s.v - d_.v_before_fail_safe;
    s.dx_prev += dt * d_.v_before_fail_safe;
  }
  if (!all.ok) ++stats.failed_contact_steps;
  d_.last_step_ok = all.ok && !overshot;
  stats.fail_safe_moves += all.fail_safe_moves;
  stats.response_seconds += seconds_since(tr);
}

void Integrator::derivative(const VecX& x, const VecX& v, VecX& a, double& viscous_power) {
  system_.evaluate(x, v, false, d_.eval);
  a = d_.eval.force.cwiseQuotient(c_.mass3);
  const auto& fixed = system_.fixed();
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) a.segment<3>(3 * i).setZero();
  viscous_power = d_.eval.viscous_power;
}

void Integrator::rk4_step(State& s, double dt, StepStatistics& stats) {
  const auto t0 = Clock::now();
  system_.begin_step(s.x, s.v, dt);
  if (!d_.handlers.empty()) d_.x_start = s.x;
  VecX a1, a2, a3, a4;
  double p1, p2, p3, p4;
  derivative(s.x, s.v, a1, p1);
  const VecX v1 = s.v;
  const VecX v2 = s.v + 0.5 * dt * a1;
  derivative(s.x + 0.5 * dt * v1, v2, a2, p2);
  const VecX v3 = s.v + 0.5 * dt * a2;
  derivative(s.x + 0.5 * dt * v2, v3, a3, p3);
  const VecX v4 = s.v + dt * a3;
  derivative(s.x + dt * v3, v4, a4, p4);
  VecX dx = dt / 6 * (v1 + 2 * v2 + 2 * v3 + v4);
  VecX dv = dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
  s.viscous_dissipated -= dt / 6 * (p1 + 2 * p2 + 2 * p3 + p4);
  s.x += dx;
  s.v += dv;
  s.dx_prev = std::move(dx);
  s.dv_prev = std::move(dv);
  s.has_history = true;
  stats.assembly_seconds += seconds_since(t0);
  if (!d_.handlers.empty()) finish_contacts(s, s.t, dt, stats);
  s.t += dt;
}

bool Integrator::rk45_try(State& s, double h, double& error_norm, StepStatistics& stats) {
  // Dormand-Prince 5(4) tableau (derivative() takes no time, so the stages' times c are
  // not needed).
  static constexpr double A[7][6] = {
      {0, 0, 0, 0, 0, 0},
      {1.0 / 5, 0, 0, 0, 0, 0},
      {3.0 / 40, 9.0 / 40, 0, 0, 0, 0},
      {44.0 / 45, -56.0 / 15, 32.0 / 9, 0, 0, 0},
      {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0, 0},
      {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0},
      {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
  static constexpr double b5[7] = {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84, 0};
  static constexpr double b4[7] = {5179.0 / 57600, 0, 7571.0 / 16695, 393.0 / 640, -92097.0 / 339200, 187.0 / 2100, 1.0 / 40};
  const auto t0 = Clock::now();
  system_.begin_step(s.x, s.v, h);
  std::vector<VecX> kx(7), kv(7);
  double power[7];
  VecX xs, vs;
  for (int st = 0; st < 7; ++st) {
    xs = s.x;
    vs = s.v;
    for (int j = 0; j < st; ++j) {
      if (A[st][j] == 0.0) continue;
      xs += h * A[st][j] * kx[j];
      vs += h * A[st][j] * kv[j];
    }
    kx[st] = vs;
    derivative(xs, vs, kv[st], power[st]);
  }
  VecX x5 = s.x, v5 = s.v, ex = VecX::Zero(s.x.size()), ev = VecX::Zero(s.x.size());
  double dissipated = 0;
  for (int st = 0; st < 7; ++st) {
    x5 += h * b5[st] * kx[st];
    v5 += h * b5[st] * kv[st];
    ex += h * (b5[st] - b4[st]) * kx[st];
    ev += h * (b5[st] - b4[st]) * kv[st];
    dissipated -= h * b5[st] * power[st];
  }
  stats.assembly_seconds += seconds_since(t0);
  const double tol = c_.settings.error_tolerance;
  double sum = 0;
  for (Eigen::Index i = 0; i < ex.size(); ++i) {
    const double sx = tol * (1 + std::max(std::abs(s.x[i]), std::abs(x5[i])));
    const double sv = tol * (1 + std::max(std::abs(s.v[i]), std::abs(v5[i])));
    sum += (ex[i] / sx) * (ex[i] / sx) + (ev[i] / sv) * (ev[i] / sv);
  }
  error_norm = std::sqrt(sum / (2.0 * ex.size()));
  if (!(error_norm <= 1.0)) return false;
  if (!d_.handlers.empty()) d_.x_start = s.x;
  s.dx_prev = x5 - s.x;
  s.dv_prev = v5 - s.v;
  s.x = x5;  // copied: x and v keep their storage (State)
  s.v = v5;
  s.viscous_dissipated += dissipated;
  s.has_history = true;
  if (!d_.handlers.empty()) finish_contacts(s, s.t, h, stats);
  s.t += h;
  return true;
}

}  // namespace weft
