#include "integrate/integrator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
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

Integrator::Integrator(System& system, IntegratorSettings settings)
    : system_(system), settings_(settings), history_(settings.warm_start_history) {
  step_.matrix.reset(system_.pattern());
  const int n = system_.num_nodes();
  mass3_.resize(3 * n);
  for (int i = 0; i < n; ++i) mass3_.segment<3>(3 * i).setConstant(system_.node_mass()[i]);
  int free_nodes = 0;
  for (char f : system_.fixed()) free_nodes += f ? 0 : 1;
  preconditioner_ = choose_preconditioner(settings_, free_nodes);
  if (settings_.newton_iterations > 0) newton_step_.matrix.reset(system_.pattern());
  guard_alphas_ = {settings_.alpha};
  for (double a : kGuardAlphas)
    if (a > settings_.alpha) guard_alphas_.push_back(a);
  // BDF-2's guard climbs to alpha = 1 (standard BDF-2), then to backward Euler; a BDF-2 at
  // alpha = 1 already goes straight to backward Euler.
  if (settings_.method == Method::Bdf2 && guard_alphas_.back() < 1.0) guard_alphas_.push_back(1.0);
}

double Integrator::ssor_relaxation() const {
  if (settings_.ssor_relaxation > 0) return settings_.ssor_relaxation;
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
  PcgSettings ps{settings_.cg_tolerance, settings_.cg_max_iterations, preconditioner_};
  ps.node_order = system_.solver_order();
  ps.ssor_omega = settings_.ssor_relaxation;
  ps.ssor_single_precision = settings_.ssor_single_precision;
  ps.ssor_whole_blocks = !handlers_.empty();
  return ps;
}

Integrator::DynamicState Integrator::dynamic_state() const {
  return {history_.snapshot(), history_alpha_,           history_beta_,          history_dt_b_,
          history_t_,          pcg_.ssor_residual_ratio, pcg_.ssor_single_fallbacks, multigrid_setup_blocks_,
          pulling_, stuck_, guard_rung_, guard_calm_steps_, guard_depth_, guard_depth_calm_steps_};
}

void Integrator::restore(const DynamicState& d) {
  const BlockPattern& P = system_.pattern();
  if (!d.multigrid_setup_blocks.empty()) {
    if (preconditioner_ != Preconditioner::kMultigrid || d.multigrid_setup_blocks.size() != static_cast<size_t>(P.num_blocks()))
      throw std::invalid_argument("the multigrid matrix does not fit this system and preconditioner");
    BlockMatrix m;
    m.reset(P);
    m.block = d.multigrid_setup_blocks;
    pcg_.multigrid.setup(m, system_.fixed(), pcg_settings().multigrid);
  }
  history_.restore(d.history);
  history_alpha_ = d.history_alpha;
  history_beta_ = d.history_beta;
  history_dt_b_ = d.history_dt_b;
  history_t_ = d.history_t;
  pcg_.ssor_residual_ratio = d.ssor_residual_ratio;
  pcg_.ssor_single_fallbacks = d.ssor_single_fallbacks;
  multigrid_setup_blocks_ = d.multigrid_setup_blocks;
  if (!d.contact_pulling.empty() && d.contact_pulling.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  if (!d.contact_stuck.empty() && d.contact_stuck.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  pulling_ = d.contact_pulling;
  stuck_ = d.contact_stuck;
  // BDF-2's guard has one rung past its alphas (backward Euler).
  const int rungs = static_cast<int>(guard_alphas_.size()) + (settings_.method == Method::Bdf2 ? 1 : 0);
  if (d.guard_rung < 0 || d.guard_rung >= rungs || d.guard_calm_steps < 0)
    throw std::invalid_argument("the guard's alpha does not fit these settings");
  if (d.guard_depth < 0 || d.guard_depth > kGuardMaxSplits || d.guard_depth_calm_steps < 0)
    throw std::invalid_argument("the guard's step depth does not fit these settings");
  guard_rung_ = d.guard_rung;
  guard_calm_steps_ = d.guard_calm_steps;
  guard_depth_ = d.guard_depth;
  guard_depth_calm_steps_ = d.guard_depth_calm_steps;
}

double Integrator::guard_alpha() const {
  return guard_rung_ < static_cast<int>(guard_alphas_.size()) ? guard_alphas_[guard_rung_] : 1.0;
}

void Integrator::advance(State& s, double t_end, StepStatistics& stats) {
  const double dt = settings_.dt;
  energy_x_.resize(0);  // the system may have changed between calls
  if (settings_.method != Method::Rk45) {
    const long steps = std::lround((t_end - s.t) / dt);
    for (long k = 0; k < steps; ++k) step(s, dt, stats);
    // No drift from summing dt. The warm-start history stays valid across the snap: it was
    // recorded at this very state, only its time is rounded differently.
    if (history_t_ == s.t) history_t_ = t_end;
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
  if (handlers_.empty()) {
    single_step(s, dt, stats);
    return;
  }
  // A step the contact handlers could not make valid is taken again as two of half the size
  // (a few times at most; the last result stands).
  State start = s;
  const std::vector<char> pulling = pulling_, stuck = stuck_;
  last_step_ok_ = true;
  single_step(s, dt, stats);
  if (last_step_ok_ || retry_depth_ >= kMaxStepHalvings) return;
  s = start;  // copied into s's own storage (State: x and v keep theirs)
  pulling_ = pulling;
  stuck_ = stuck;
  history_.clear();
  ++stats.halved_steps;
  ++retry_depth_;
  step(s, 0.5 * dt, stats);
  step(s, 0.5 * dt, stats);
  --retry_depth_;
  --stats.steps;  // the attempt that was taken again is not an accepted step
}

void Integrator::single_step(State& s, double dt, StepStatistics& stats) {
  const double alpha = settings_.alpha;
  switch (settings_.method) {
    case Method::ForwardEuler:
      linear_step(s, dt, 0.0, 0.0, dt, stats);
      break;
    case Method::AlphaFamily:
      if (settings_.guard) {
        guarded_parts(s, dt, stats);
      } else {
        linear_step(s, dt, alpha, 0.0, dt, stats);
      }
      break;
    case Method::Bdf2:
      if (settings_.guard) {
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
  if (!(energy_x_.size() == x.size() && energy_x_ == x)) {
    system_.potential_energy(x, energy_elastic_, energy_gravity_);
    energy_x_ = x;
  }
  elastic = energy_elastic_;
  gravity = energy_gravity_;
}

void Integrator::bdf2_step(State& s, double dt, double alpha, StepStatistics& stats) {
  if (!s.has_history) {
    linear_step(s, dt, alpha, 0.0, dt, stats);  // start with one alpha-family step
  } else {
    // METHOD.md 2: beta = (2 alpha - 1)/(2 alpha + 1), dt_b = 2 dt/(2 alpha + 1)
    linear_step(s, dt, alpha, (2 * alpha - 1) / (2 * alpha + 1), 2 * dt / (2 * alpha + 1), stats);
  }
}

double Integrator::kinetic_energy(const VecX& v) const {
  return 0.5 * mass3_.dot(v.cwiseAbs2());
}

// The energy balance of one step: with static pins, gravity the only external force and the
// contacts' work counted in State::contact_work, the mechanical energy can only fall by the
// viscous work and what contacts took (METHOD.md 6). Linearised Implicit Midpoint does not
// keep to it where elements are stiff and turn within the step (docs/guarded-midpoint.md): a
// step that breaks it is taken again from its start as two halves, and where a sixteenth of
// the step still breaks it, with the next larger alpha (numerical dissipation of order
// (2 alpha - 1), only while it is needed). The start's energy comes with the step's assembly;
// the end's costs one evaluation without Jacobians.
void Integrator::guarded_parts(State& s, double dt, StepStatistics& stats) {
  // A step the last steps had to halve starts halved as often (no attempt at the full step to
  // discard); the depth goes back up one halving after every kGuardRelaxSteps steps that needed
  // no deeper one.
  guard_raised_now_ = false;
  const int depth = guard_depth_;
  const int parts = 1 << depth;
  for (int k = 0; k < parts; ++k) guarded_step(s, dt / parts, stats, depth);
  if (guard_raised_now_) ++stats.guard_raised_steps;
  if (guard_depth_ > depth) {
    guard_depth_calm_steps_ = 0;
  } else if (guard_depth_ > 0 && ++guard_depth_calm_steps_ >= kGuardRelaxSteps) {
    --guard_depth_;
    guard_depth_calm_steps_ = 0;
  }
}

void Integrator::guarded_step(State& s, double dt, StepStatistics& stats, int splits) {
  auto tg = Clock::now();
  guard_start_ = s;
  const std::vector<char> pulling = pulling_, stuck = stuck_;
  const int top = static_cast<int>(guard_alphas_.size()) - 1;
  for (;;) {
    const double alpha = guard_alphas_[guard_rung_];
    stats.guard_seconds += seconds_since(tg);
    linear_step(s, dt, alpha, 0.0, dt, stats);
    tg = Clock::now();
    if (!puts_energy_in(s)) break;
    stats.guard_seconds += seconds_since(tg);
    tg = Clock::now();
    if (splits < kGuardMaxSplits) {
      // Halving the step divides kappa by 4 and the elements' turn within the step by 2 while
      // keeping the step second order: on the stiff swing it dissipates a third of what
      // raising alpha does (docs/guarded-midpoint.md).
      s = guard_start_;
      pulling_ = pulling;
      stuck_ = stuck;
      ++stats.guard_split_steps;
      guard_depth_ = std::max(guard_depth_, splits + 1);
      guarded_step(s, 0.5 * dt, stats, splits + 1);
      guarded_step(s, 0.5 * dt, stats, splits + 1);
      return;
    }
    if (guard_rung_ == top) break;
    // Still putting energy in at a sixteenth of the step: a larger alpha, which stays raised
    // for a few steps.
    s = guard_start_;
    pulling_ = pulling;
    stuck_ = stuck;
    ++guard_rung_;
    guard_calm_steps_ = 0;
    ++stats.guard_redone_steps;
  }
  stats.guard_seconds += seconds_since(tg);
  accept_guarded(guard_alphas_[guard_rung_], stats);
}

bool Integrator::puts_energy_in(const State& s) {
  const double kinetic0 = kinetic_energy(guard_start_.v);
  const double e0 = kinetic0 + step_.elastic_energy + step_.gravity_energy;
  const double scale = std::max(energy_scale_, kinetic0 + step_.elastic_energy);
  double elastic1, gravity1;
  potential_energy(s.x, elastic1, gravity1);
  const double e1 = kinetic_energy(s.v) + elastic1 + gravity1;
  const double gain = (e1 - e0) + (s.viscous_dissipated - guard_start_.viscous_dissipated) -
                      (s.contact_work - guard_start_.contact_work);
  // A non-finite end is a step that put energy in too.
  return !(gain <= kGuardTolerance * scale);
}

void Integrator::accept_guarded(double alpha, StepStatistics& stats, int parts) {
  stats.guard_parts += parts;
  if (guard_rung_ > 0) {
    guard_raised_now_ = true;
    stats.guard_max_alpha = std::max(stats.guard_max_alpha, alpha);
    if (++guard_calm_steps_ >= kGuardRelaxSteps) {
      --guard_rung_;
      guard_calm_steps_ = 0;
    }
  }
}

// The guard for BDF-2 (alpha family of BDF-2 steps, METHOD.md 2): the same energy balance as
// guarded_step. A step that breaks it is taken again from its start with the next larger alpha
// (up to alpha = 1, standard BDF-2, whose numerical dissipation of fast modes is strongest),
// and past that as a backward Euler step, which needs no history; where even that puts energy
// in, as backward Euler halves (backward_euler_parts). BDF-2 steps themselves are not halved:
// their history holds the last step's displacement and change of velocity at the step's own
// size. The rung reached stays for the next steps and relaxes as in guarded_step.
void Integrator::guarded_bdf2_step(State& s, double dt, StepStatistics& stats) {
  auto tg = Clock::now();
  guard_start_ = s;
  const std::vector<char> pulling = pulling_, stuck = stuck_;
  const int backward_euler = static_cast<int>(guard_alphas_.size());  // the rung past the alphas
  guard_raised_now_ = false;
  for (;;) {
    stats.guard_seconds += seconds_since(tg);
    if (guard_rung_ == backward_euler) {
      linear_step(s, dt, 1.0, 0.0, dt, stats);
    } else {
      bdf2_step(s, dt, guard_alphas_[guard_rung_], stats);
    }
    tg = Clock::now();
    if (!puts_energy_in(s)) break;
    s = guard_start_;
    pulling_ = pulling;
    stuck_ = stuck;
    if (guard_rung_ == backward_euler) {
      // Backward Euler still puts energy in (an element turning fast): its halves, each
      // checked and halved again the same way (kGuardMaxSplits times at most).
      ++stats.guard_split_steps;
      stats.guard_seconds += seconds_since(tg);
      int parts = 0;
      backward_euler_parts(s, 0.5 * dt, stats, 1, parts);
      backward_euler_parts(s, 0.5 * dt, stats, 1, parts);
      accept_guarded(1.0, stats, parts);
      if (guard_raised_now_) ++stats.guard_raised_steps;
      return;
    }
    ++guard_rung_;
    guard_calm_steps_ = 0;
    ++stats.guard_redone_steps;
  }
  stats.guard_seconds += seconds_since(tg);
  accept_guarded(guard_rung_ == backward_euler ? 1.0 : guard_alphas_[guard_rung_], stats);
  if (guard_raised_now_) ++stats.guard_raised_steps;
}

void Integrator::backward_euler_parts(State& s, double dt, StepStatistics& stats, int splits, int& parts) {
  auto tg = Clock::now();
  guard_start_ = s;
  const std::vector<char> pulling = pulling_, stuck = stuck_;
  stats.guard_seconds += seconds_since(tg);
  linear_step(s, dt, 1.0, 0.0, dt, stats);
  tg = Clock::now();
  if (splits >= kGuardMaxSplits || !puts_energy_in(s)) {
    ++parts;
    stats.guard_seconds += seconds_since(tg);
    return;
  }
  s = guard_start_;
  pulling_ = pulling;
  stuck_ = stuck;
  ++stats.guard_split_steps;
  stats.guard_seconds += seconds_since(tg);
  backward_euler_parts(s, 0.5 * dt, stats, splits + 1, parts);
  backward_euler_parts(s, 0.5 * dt, stats, splits + 1, parts);
}

void Integrator::linear_step(State& s, double dt, double alpha, double beta, double dt_b,
                             StepStatistics& stats) {
  const auto t0 = Clock::now();
  system_.begin_step(s.x, s.v, dt);
  const BlockPattern& P = system_.pattern();
  const int n = system_.num_nodes();
  const VecX& m = system_.node_mass();
  // w = beta dx_p + dt_b v, so that the right-hand side is
  //   beta M dv_p + dt_b f + alpha dt_b K w
  // and the matrix M - alpha dt_b D - alpha^2 dt_b^2 K (METHOD.md 1-2).
  tmp_ = dt_b * s.v;
  if (beta != 0.0) tmp_ += beta * s.dx_prev;
  step_.ck = alpha * alpha * dt_b * dt_b;
  step_.cd = alpha * dt_b;
  system_.assemble_step(s.x, s.v, tmp_, step_);
  rhs_ = dt_b * step_.force;
  if (beta != 0.0) rhs_ += beta * mass3_.cwiseProduct(s.dv_prev);
  if (alpha > 0.0) rhs_ += alpha * dt_b * step_.stiffness_times_w;
  for (int i = 0; i < n; ++i) step_.matrix.block[P.diagonal_slot(i)].diagonal().array() += m[i];
  stats.assembly_seconds += seconds_since(t0);

  const auto t1 = Clock::now();
  // Warm start: the combination of the last steps' solutions whose right-hand sides best fit
  // this one (SolutionHistory), else the previous change in velocity.
  if (alpha != history_alpha_ || beta != history_beta_ || dt_b != history_dt_b_ ||
      s.t != history_t_) {
    history_.clear();
    history_alpha_ = alpha;
    history_beta_ = beta;
    history_dt_b_ = dt_b;
  }
  if (!history_.guess(rhs_, dv_)) {
    if (s.dv_prev.size() == 3 * n) dv_ = s.dv_prev; else dv_ = VecX::Zero(3 * n);
  }
  // Contacts (semi-implicit steps that depend on dv): detected at the step's start, held by
  // the solve as constraints.
  contacts_.clear();
  if (!handlers_.empty()) {
    const auto td = Clock::now();
    for (ContactHandler* h : handlers_) h->detect(s.x, s.v, s.t, dt, contacts_);
    if (pulling_.size() != static_cast<size_t>(n)) pulling_.assign(n, 0);
    size_t kept = 0;
    for (const NodeContact& c : contacts_) {
      if (pulling_[c.node] && !c.penetrating && !c.kinematic) {
        ++stats.released_contacts;
        continue;
      }
      contacts_[kept++] = c;
    }
    contacts_.resize(kept);
    std::fill(pulling_.begin(), pulling_.end(), 0);
    stats.detection_seconds += seconds_since(td);
  }
  if (alpha == 0.0) contacts_.clear();  // dx does not depend on dv: the fail-safe alone acts
  if (!handlers_.empty()) {
    // A node that ended the last step stuck to a surface starts this one stuck.
    if (stuck_.size() != static_cast<size_t>(n)) stuck_.assign(n, 0);
    contact_stuck_.resize(contacts_.size());
    for (size_t k = 0; k < contacts_.size(); ++k)
      contact_stuck_[k] = contacts_[k].kinematic || (stuck_[contacts_[k].node] && contacts_[k].friction > 0);
    std::fill(stuck_.begin(), stuck_.end(), 0);
  }

  const PcgSettings ps = pcg_settings();
  if (preconditioner_ == Preconditioner::kMultigrid && !pcg_.multigrid.matches(P, system_.fixed(), ps.multigrid)) {
    // Built here rather than inside the solve, to keep the matrix it was built from.
    pcg_.multigrid.setup(step_.matrix, system_.fixed(), ps.multigrid);
    multigrid_setup_blocks_ = step_.matrix.block;
  }
  // With contacts, an active set: the solve holds the detected contacts; nodes it would leave
  // inside a collider's thickness at the step's end join them and the step is solved again
  // (a few times at most; the handler's fail-safe catches what remains).
  if (!contacts_.empty() || (!handlers_.empty() && alpha > 0.0)) rhs_unconstrained_ = rhs_;
  PcgResult r;
  for (int pass = 0;; ++pass) {
    if (!contacts_.empty()) {
      const auto tr = Clock::now();
      constrain(s, dt, alpha, beta, dt_b);
      stats.response_seconds += seconds_since(tr);
    }
    r = solve_pcg(step_.matrix, rhs_, system_.fixed(), ps, dv_, pcg_);
    stats.cg_iterations += r.iterations;
    ++stats.cg_solves;
    if (!r.converged) ++stats.cg_failures;
    if (contacts_.empty() && pass == 0) {
      if (r.converged) history_.record(rhs_, system_.fixed(), dv_);
    }
    if (!contacts_.empty()) {
      const auto tr = Clock::now();
      unconstrain(dt, dt_b);
      rhs_ = rhs_unconstrained_;
      stats.response_seconds += seconds_since(tr);
    }
    if (handlers_.empty() || alpha == 0.0 || pass + 1 >= kMaxContactPasses) break;
    // Contacts that pull are let go (a node stays held when it was let go before in this step
    // and came back, or starts inside the collider); nodes that would end inside join.
    const auto td = Clock::now();
    if (pass == 0) {
      released_now_.assign(n, 0);
      keep_held_.assign(n, 0);
    }
    bool changed = false;
    size_t kept = 0;
    const VecX& mass = system_.node_mass();
    for (size_t k = 0; k < contacts_.size(); ++k) {
      const NodeContact& c = contacts_[k];
      const Vec3& J = contact_impulse_[k];
      const double normal_impulse = c.normal.dot(J);
      // A stuck contact whose impulse left the friction cone slides.
      if (contact_stuck_[k] && !c.kinematic &&
          (J - c.normal * normal_impulse).norm() > c.friction * std::max(normal_impulse, 0.0)) {
        contact_stuck_[k] = 0;
        changed = true;
      }
      if (normal_impulse < -kReleaseSpeed * mass[c.node] && !c.penetrating && !c.kinematic && !keep_held_[c.node]) {
        released_now_[c.node] = 1;
        ++stats.released_contacts;
        changed = true;
        continue;
      }
      contact_stuck_[kept] = contact_stuck_[k];
      contacts_[kept++] = c;
    }
    contacts_.resize(kept);
    contact_stuck_.resize(kept);
    tmp2_ = s.x + dt_b * (s.v + alpha * dv_);
    if (beta != 0.0) tmp2_ += beta * s.dx_prev;
    held_.assign(n, 0);
    for (const NodeContact& c : contacts_) held_[c.node] = 1;
    const size_t before = contacts_.size();
    for (ContactHandler* h : handlers_) h->detect_end(s.x, tmp2_, s.t, dt, held_, contacts_);
    contact_stuck_.resize(contacts_.size(), 0);  // those that join slide
    for (size_t k = before; k < contacts_.size(); ++k)
      if (released_now_[contacts_[k].node]) keep_held_[contacts_[k].node] = 1;
    stats.detection_seconds += seconds_since(td);
    if (contacts_.size() != before) changed = true;
    if (!changed) break;
    ++stats.contact_passes;
  }
  if (!contacts_.empty()) {
    stats.contacts += static_cast<long>(contacts_.size());
    stats.max_contacts = std::max(stats.max_contacts, static_cast<long>(contacts_.size()));
    if (r.converged) history_.record(rhs_, system_.fixed(), dv_);
  }
  stats.solve_seconds += seconds_since(t1);
  const int newton_iterations = settings_.newton_iterations > 0 && alpha > 0.0 && contacts_.empty()
                                    ? newton_iterate(s, alpha, beta, dt_b, stats)
                                    : 0;
  if (!handlers_.empty()) x_start_ = s.x;

  // dx = beta dx_p + dt_b (v + alpha dv), built in dx_prev's storage (no allocation per step);
  // tmp_ holds the mean velocity dx/dt.
  if (beta != 0.0) {
    s.dx_prev = beta * s.dx_prev + dt_b * (s.v + alpha * dv_);
  } else {
    s.dx_prev = dt_b * (s.v + alpha * dv_);
  }
  // Viscous work over the step, at the start's positions with the step's mean velocity
  // dx/dt (METHOD.md 6); for forward Euler the start's velocity. A step Newton iterated
  // evaluated its forces at x_a = x + alpha dx: its viscous force does its work there.
  if (newton_iterations > 0) {
    tmp_ = s.dx_prev / dt;
    tmp2_ = s.x + alpha * s.dx_prev;
    s.viscous_dissipated -= dt * system_.viscous_power(tmp2_, tmp_);
  } else if (alpha > 0.0) {
    tmp_ = s.dx_prev / dt;
    s.viscous_dissipated -= dt * system_.step_viscous_power(s.x, tmp_, step_);
  } else {
    s.viscous_dissipated -= dt * step_.viscous_power;
  }
  s.x += s.dx_prev;
  s.v += dv_;
  s.dv_prev = dv_;
  s.has_history = true;
  if (!handlers_.empty()) {
    const auto tr = Clock::now();
    contact_velocities(s, dt, dt_b);
    stats.response_seconds += seconds_since(tr);
    finish_contacts(s, s.t, dt, stats);
  }
  s.t += dt;
  history_t_ = s.t;
}

double Integrator::newton_residual(const State& s, double alpha, double beta, double dt_b, const VecX& dv,
                                   VecX& r) {
  newton_v_ = s.v + alpha * dv;
  newton_x_ = s.x + (alpha * dt_b) * newton_v_;
  if (beta != 0.0) newton_x_ += (alpha * beta) * s.dx_prev;
  system_.evaluate(newton_x_, newton_v_, false, eval_);
  r = dt_b * eval_.force - mass3_.cwiseProduct(dv);
  if (beta != 0.0) r += beta * mass3_.cwiseProduct(s.dv_prev);
  const auto& fixed = system_.fixed();
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) r.segment<3>(3 * i).setZero();
  return std::sqrt(r.cwiseAbs2().cwiseQuotient(mass3_).sum());
}

// Newton's method on the step's equations before linearisation (METHOD.md 1-2): the step
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
int Integrator::newton_iterate(const State& s, double alpha, double beta, double dt_b, StepStatistics& stats) {
  const auto t0 = Clock::now();
  const VecX& m = system_.node_mass();
  const BlockPattern& P = system_.pattern();
  const int n = system_.num_nodes();
  const double rhs_norm = std::sqrt(rhs_.cwiseAbs2().cwiseQuotient(mass3_).sum());
  double residual = newton_residual(s, alpha, beta, dt_b, dv_, newton_r_);
  auto converged = [&] {
    const double dv_norm = std::sqrt(mass3_.dot(dv_.cwiseAbs2()));
    return residual <= settings_.newton_tolerance * std::max(dv_norm, rhs_norm);
  };
  int taken = 0, moved = 0;
  bool stuck = false;
  while (std::isfinite(residual) && !converged() && taken < settings_.newton_iterations) {
    newton_step_.ck = alpha * alpha * dt_b * dt_b;
    newton_step_.cd = alpha * dt_b;
    newton_w_.setZero(3 * n);
    system_.assemble_step(newton_x_, newton_v_, newton_w_, newton_step_);
    for (int i = 0; i < n; ++i) newton_step_.matrix.block[P.diagonal_slot(i)].diagonal().array() += m[i];
    newton_delta_.setZero(3 * n);
    const PcgResult r = solve_pcg(newton_step_.matrix, newton_r_, system_.fixed(), pcg_settings(), newton_delta_, pcg_);
    stats.cg_iterations += r.iterations;
    ++stats.cg_solves;
    if (!r.converged) ++stats.cg_failures;
    ++taken;
    double fraction = 1.0;
    bool accepted = false;
    for (int halving = 0; halving <= kNewtonMaxHalvings; ++halving) {
      newton_dv_trial_ = dv_ + fraction * newton_delta_;
      const double trial = newton_residual(s, alpha, beta, dt_b, newton_dv_trial_, newton_r_trial_);
      if (trial <= (1.0 - 1e-4 * fraction) * residual) {
        dv_.swap(newton_dv_trial_);
        newton_r_.swap(newton_r_trial_);
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
  if (taken > 0) {
    ++stats.newton_steps;
    stats.newton_iterations += taken;
  }
  if (stuck || !converged()) ++stats.newton_unconverged;
  stats.newton_seconds += seconds_since(t0);
  return moved;
}

// The contact constraints (Baraff and Witkin's filters, docs/collisions.md). A sliding contact
// at node i with normal n prescribes dv_i . n and leaves dv_i's tangential part free,
// S_i = I - n n^T; a sticking one prescribes all of dv_i (S_i = 0), the node moving with the
// surface. Writing dv = y + z with y_i in S_i's range and z_i the prescribed part, the solve's
// equations are the free directions' ones, S (A (y + z) - b) = 0, that is
//   (S A S + c (I - S)) y = S (b - A z)
// where the c (I - S) term (c the node's mean diagonal stiffness) only keeps the matrix positive
// definite: its (I - S) rows give (I - S) y = 0. The matrix keeps A's pattern and is symmetric
// positive definite, so every preconditioner solves it unchanged; the changed blocks are put
// back after the solve. z is chosen so that the step's displacement beta dx_p + dt_b (v +
// alpha dv) has the prescribed part.
Mat3 Integrator::contact_filter(size_t k) const {
  const Vec3& n = contacts_[k].normal;
  return contact_stuck_[k] ? Mat3(Mat3::Zero()) : Mat3(Mat3::Identity() - n * n.transpose());
}

void Integrator::constrain(const State& s, double dt, double alpha, double beta, double dt_b) {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  std::vector<Mat3>& blocks = step_.matrix.block;
  const size_t count = contacts_.size();
  contact_dv_.resize(count);
  contact_rhs_.resize(count);
  if (slot_saved_.size() != blocks.size()) slot_saved_.assign(blocks.size(), 0);
  saved_blocks_.clear();
  auto save = [&](int slot) {
    if (slot_saved_[slot]) return;
    slot_saved_[slot] = 1;
    saved_blocks_.emplace_back(slot, blocks[slot]);
  };
  // z, and b - A z with the original blocks.
  for (size_t k = 0; k < count; ++k) {
    const NodeContact& c = contacts_[k];
    const int i = c.node;
    const Mat3 S = contact_filter(k);
    // The prescribed displacement: along the normal, and when stuck the surface's tangential one.
    Vec3 target = c.normal * c.normal_displacement;
    if (c.kinematic) {
      target = c.displacement;
    } else if (contact_stuck_[k]) {
      target += dt * (c.surface_velocity - c.normal * c.normal.dot(c.surface_velocity));
    }
    if (beta != 0.0) target -= beta * node(s.dx_prev, i);
    contact_dv_[k] = (Mat3::Identity() - S) * ((target / dt_b - node(s.v, i)) / alpha);
    contact_rhs_[k] = node(rhs_, i);
  }
  for (size_t k = 0; k < count; ++k) {
    const int i = contacts_[k].node;
    const Vec3& z = contact_dv_[k];
    for (int e = row_start[i]; e < row_start[i + 1]; ++e)
      node(rhs_, column[e]) -= blocks[e].transpose() * z;  // A_ji = A_ij^T
  }
  // S (b - A z) and the warm start's y in the free directions.
  for (size_t k = 0; k < count; ++k) {
    const int i = contacts_[k].node;
    const Mat3 S = contact_filter(k);
    node(rhs_, i) = S * node(rhs_, i);
    node(dv_, i) = S * node(dv_, i);
  }
  // S_i A_ij and A_ji S_i for every contact i (both: S_i A_ij S_j), the diagonal blocks last.
  for (size_t k = 0; k < count; ++k) {
    const int i = contacts_[k].node;
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
    const int i = contacts_[k].node;
    const Mat3 S = contact_filter(k);
    const int d = P.diagonal_slot(i);
    save(d);
    Mat3& a = blocks[d];
    const double c = a.trace() / 3;
    a = S * a * S + c * (Mat3::Identity() - S);
  }
  step_.matrix.constants_changed();
}

void Integrator::unconstrain(double dt, double dt_b) {
  const BlockPattern& P = system_.pattern();
  const auto& row_start = P.row_start();
  const auto& column = P.column();
  std::vector<Mat3>& blocks = step_.matrix.block;
  for (const auto& [slot, value] : saved_blocks_) {
    blocks[slot] = value;
    slot_saved_[slot] = 0;
  }
  saved_blocks_.clear();
  step_.matrix.constants_changed();
  const size_t count = contacts_.size();
  contact_impulse_.resize(count);
  for (size_t k = 0; k < count; ++k) {
    const int i = contacts_[k].node;
    node(dv_, i) = contact_filter(k) * node(dv_, i) + contact_dv_[k];
  }
  // The constraint's impulse: what A dv - b leaves at the node, dt_b times the contact force.
  for (size_t k = 0; k < count; ++k) {
    const int i = contacts_[k].node;
    Vec3 a_dv = Vec3::Zero();
    for (int e = row_start[i]; e < row_start[i + 1]; ++e) a_dv += blocks[e] * node(dv_, column[e]);
    contact_impulse_[k] = (dt / dt_b) * (a_dv - contact_rhs_[k]);
  }
}

void Integrator::contact_velocities(State& s, double dt, double dt_b) {
  const VecX& m = system_.node_mass();
  for (size_t k = 0; k < contacts_.size(); ++k) {
    const NodeContact& c = contacts_[k];
    const int i = c.node;
    const Vec3& J = contact_impulse_[k];
    const double normal_impulse = c.normal.dot(J);
    if (normal_impulse < -kReleaseSpeed * m[i] && !c.kinematic) pulling_[i] = 1;
    // The work of the constraint's impulse over the step's displacement.
    s.contact_work += J.dot(node(s.x, i) - node(x_start_, i)) / dt;
    const Vec3 v_old = node(s.v, i);
    Vec3 v_new;
    if (c.kinematic) {
      v_new = c.surface_velocity;
    } else if (contact_stuck_[k]) {
      // Stuck: the node leaves the step moving with the surface, and stays stuck.
      v_new = c.surface_velocity;
      stuck_[i] = 1;
    } else {
      // Sliding: Coulomb friction takes up to friction * impulse / m off the sliding speed (a
      // change of velocity after the step, which only takes kinetic energy out); a node it
      // stops is stuck from the next step on. Along the normal the contact is inelastic: the
      // node leaves the step moving with the surface.
      const Vec3 u = v_old - c.surface_velocity;
      const Vec3 ut = u - c.normal * c.normal.dot(u);
      const double slide = ut.norm();
      // (For BDF-2, whose step applies a force over dt_b and repeats the last change of
      // velocity by beta, the change is dt_b / dt of the impulse's: the sliding then slows by
      // exactly friction * impulse / m per step, as with the other methods.)
      const double stop = (dt_b / dt) * c.friction * std::max(normal_impulse, 0.0) / m[i];
      const bool stops = c.friction > 0 && slide <= stop;
      v_new = c.surface_velocity + (stops ? 0.0 : 1 - stop / slide) * ut;
      stuck_[i] = stops ? 1 : 0;
    }
    node(s.v, i) = v_new;
    // BDF-2's history as if the node had moved at its new velocity: the change of velocity as
    // taken, the displacement changed by dt times the correction (a node stopped by friction
    // is then at rest for the next step, not carrying the step's sliding).
    node(s.dv_prev, i) += v_new - v_old;
    node(s.dx_prev, i) += dt * (v_new - v_old);
    s.contact_work += 0.5 * m[i] * (v_new.squaredNorm() - v_old.squaredNorm());
  }
}

void Integrator::finish_contacts(State& s, double t0, double dt, StepStatistics& stats) {
  const auto tr = Clock::now();
  v_before_fail_safe_ = s.v;
  // The fail-safes first, then the handlers that prescribe motions (clamps), which have the
  // last word on their vertices. Each group's work is the whole change of mechanical energy it
  // made: besides the kinetic energy of its changes of velocity (report.work), moving a vertex
  // changes the elastic and gravitational energy, which the balance would otherwise book as
  // the integrator's. The fail-safes' share is kept apart (State::fail_safe_work).
  ContactReport all;
  for (bool prescribed : {false, true}) {
    ContactReport report;
    x_before_fail_safe_ = s.x;
    VecX& v_before = v_before_group_;
    v_before = s.v;
    for (ContactHandler* h : handlers_)
      if (h->prescribes_motion() == prescribed) h->finish_step(x_start_, s.x, s.v, t0, dt, report);
    if (report.fail_safe_moves > 0) {
      double elastic, gravity;
      potential_energy(x_before_fail_safe_, elastic, gravity);
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
    v_before_fail_safe_ = s.v - v_before_fail_safe_;
    s.dx_prev += dt * v_before_fail_safe_;
  }
  if (!all.ok) ++stats.failed_contact_steps;
  last_step_ok_ = all.ok;
  stats.fail_safe_moves += all.fail_safe_moves;
  stats.response_seconds += seconds_since(tr);
}

void Integrator::derivative(const VecX& x, const VecX& v, VecX& a, double& viscous_power) {
  system_.evaluate(x, v, false, eval_);
  a = eval_.force.cwiseQuotient(mass3_);
  const auto& fixed = system_.fixed();
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) a.segment<3>(3 * i).setZero();
  viscous_power = eval_.viscous_power;
}

void Integrator::rk4_step(State& s, double dt, StepStatistics& stats) {
  const auto t0 = Clock::now();
  system_.begin_step(s.x, s.v, dt);
  if (!handlers_.empty()) x_start_ = s.x;
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
  if (!handlers_.empty()) finish_contacts(s, s.t, dt, stats);
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
  const double tol = settings_.error_tolerance;
  double sum = 0;
  for (Eigen::Index i = 0; i < ex.size(); ++i) {
    const double sx = tol * (1 + std::max(std::abs(s.x[i]), std::abs(x5[i])));
    const double sv = tol * (1 + std::max(std::abs(s.v[i]), std::abs(v5[i])));
    sum += (ex[i] / sx) * (ex[i] / sx) + (ev[i] / sv) * (ev[i] / sv);
  }
  error_norm = std::sqrt(sum / (2.0 * ex.size()));
  if (!(error_norm <= 1.0)) return false;
  if (!handlers_.empty()) x_start_ = s.x;
  s.dx_prev = x5 - s.x;
  s.dv_prev = v5 - s.v;
  s.x = x5;  // copied: x and v keep their storage (State)
  s.v = v5;
  s.viscous_dissipated += dissipated;
  s.has_history = true;
  if (!handlers_.empty()) finish_contacts(s, s.t, h, stats);
  s.t += h;
  return true;
}

}  // namespace weft
