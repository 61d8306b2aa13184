#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "util/timer.hpp"

namespace weft {

const std::vector<MethodInfo>& method_table() {
  static const std::vector<MethodInfo> table = {
      {"forward-euler", Method::kForwardEuler, 0.0, 0.0, "explicit Euler (alpha family, alpha = 0)"},
      {"implicit-midpoint", Method::kAlphaFamily, 0.5, 0.5,
       "alpha family, alpha = 1/2 (second order), with the energy guard: a step that would put energy in "
       "is taken again as two halves, then with a larger alpha",
       true},
      {"implicit-midpoint-plain", Method::kAlphaFamily, 0.5, 0.5,
       "alpha family, alpha = 1/2 (second order), without the energy guard (the paper's step)"},
      {"backward-euler", Method::kAlphaFamily, 1.0, 1.0, "alpha family, alpha = 1 (first order, dissipative)"},
      {"alpha", Method::kAlphaFamily, std::nullopt, 0.5, "alpha family with the given --alpha in [0, 1]"},
      {"bdf2", Method::kBdf2, 1.0, 1.0, "progressive BDF-2, alpha = 1 (standard BDF-2)"},
      {"bdf2-alpha", Method::kBdf2, std::nullopt, 1.0 / std::sqrt(3.0),
       "progressive BDF-2 with the given alpha (default 1/sqrt(3))"},
      {"bdf2-alpha-guarded", Method::kBdf2, std::nullopt, 1.0 / std::sqrt(3.0),
       "progressive BDF-2 with the given alpha (default 1/sqrt(3)) and the energy guard: a step that would "
       "put energy in is taken again with a larger alpha, up to standard BDF-2, then as a backward Euler step",
       true},
      {"rk4", Method::kRk4, std::nullopt, 0.0, "classical explicit Runge-Kutta, fourth order"},
      {"rk45", Method::kRk45, std::nullopt, 0.0,
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
  for (char f : system.pinned()) free_nodes += f ? 0 : 1;
  c.preconditioner = choose_preconditioner(settings, free_nodes);
  c.guard_alphas = {settings.alpha};
  for (double a : kGuardAlphas)
    if (a > settings.alpha) c.guard_alphas.push_back(a);
  // BDF-2's guard climbs to alpha = 1 (standard BDF-2), then to backward Euler; a BDF-2 at
  // alpha = 1 already goes straight to backward Euler.
  if (settings.method == Method::kBdf2 && c.guard_alphas.back() < 1.0) c.guard_alphas.push_back(1.0);
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
  for (char f : system_.pinned()) free_nodes += f ? 0 : 1;
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
    d_.pcg.multigrid.setup(m, system_.pinned(), pcg_settings().multigrid);
  }
  if (!d_.pulling.empty() && d_.pulling.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  if (!d_.stuck.empty() && d_.stuck.size() != static_cast<size_t>(system_.num_nodes()))
    throw std::invalid_argument("the contact flags do not fit this system");
  // BDF-2's guard has one rung past its alphas (backward Euler).
  const int rungs = static_cast<int>(c_.guard_alphas.size()) + (c_.settings.method == Method::kBdf2 ? 1 : 0);
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
  if (c_.settings.method != Method::kRk45) {
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
  if (d_.last_step_ok || d_.retry_depth >= c_.settings.max_step_halvings) return;
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
    case Method::kForwardEuler:
      linear_step(s, dt, 0.0, 0.0, dt, stats);
      break;
    case Method::kAlphaFamily:
      if (c_.settings.guard) {
        guarded_parts(s, dt, stats);
      } else if (alpha == 1.0 && c_.settings.backward_euler_newton && newton_limit() < kBackwardEulerNewton) {
        backward_euler_step(s, dt, stats);
      } else {
        linear_step(s, dt, alpha, 0.0, dt, stats);
      }
      break;
    case Method::kBdf2:
      if (c_.settings.guard) {
        guarded_bdf2_step(s, dt, stats);
      } else {
        bdf2_step(s, dt, alpha, stats);
      }
      break;
    case Method::kRk4:
      rk4_step(s, dt, stats);
      break;
    case Method::kRk45: {
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

// A semi-implicit step (docs/method.md 1-2) as its stages: assembly, the warm start, the
// contacts at the step's start, the solve with its contacts (the active set's passes, or the
// bounded solve), Newton iterations where asked, the step taken, then the contacts' velocities
// and the fail-safes.
void Integrator::linear_step(State& s, double dt, double alpha, double beta, double dt_b,
                             StepStatistics& stats) {
  assemble_linear_step(s, dt, alpha, beta, dt_b, stats);
  const auto t1 = Clock::now();
  // The contacts' detection and response within the solve's passes count as theirs, not the
  // solve's: the split of a step's time adds up to it.
  const double contact_seconds_before = stats.detection_seconds + stats.response_seconds;
  warm_start(s, alpha, beta, dt_b);
  detect_contacts(s, dt, alpha, stats);
  solve_with_contacts(s, dt, alpha, beta, dt_b, stats);
  stats.solve_seconds += seconds_since(t1) - (stats.detection_seconds + stats.response_seconds - contact_seconds_before);
  const int newton_iterations =
      newton_limit() > 0 && alpha > 0.0 ? newton_iterate(s, dt, alpha, beta, dt_b, stats) : 0;
  if (!d_.handlers.empty()) d_.x_start = s.x;
  take_step(s, dt, alpha, beta, dt_b, newton_iterations);
  if (!d_.handlers.empty()) {
    const auto tr = Clock::now();
    contact_velocities(s, dt, dt_b);
    stats.response_seconds += seconds_since(tr);
    finish_contacts(s, s.t, dt, stats);
  }
  s.t += dt;
  d_.history_t = s.t;
}

void Integrator::assemble_linear_step(const State& s, double dt, double alpha, double beta, double dt_b,
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
}

void Integrator::warm_start(const State& s, double alpha, double beta, double dt_b) {
  const int n = system_.num_nodes();
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
}

void Integrator::detect_contacts(const State& s, double dt, double alpha, StepStatistics& stats) {
  const int n = system_.num_nodes();
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
}

void Integrator::solve_with_contacts(const State& s, double dt, double alpha, double beta, double dt_b,
                                     StepStatistics& stats) {
  const BlockPattern& P = system_.pattern();
  const PcgSettings ps = pcg_settings();
  if (c_.preconditioner == Preconditioner::kMultigrid && !d_.pcg.multigrid.matches(P, system_.pinned(), ps.multigrid)) {
    // Built here rather than inside the solve, to keep the matrix it was built from.
    d_.pcg.multigrid.setup(d_.step.matrix, system_.pinned(), ps.multigrid);
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
      r = solve_pcg(d_.step.matrix, d_.rhs, system_.pinned(), ps, d_.dv, d_.pcg);
      stats.cg_iterations += r.iterations;
      ++stats.cg_solves;
      if (!r.converged) ++stats.cg_failures;
      if (d_.contacts.empty() && pass == 0) {
        if (r.converged) d_.history.record(d_.rhs, system_.pinned(), d_.dv);
      }
      if (!d_.contacts.empty()) {
        const auto tr = Clock::now();
        unconstrain(dt, dt_b);
        d_.rhs = d_.rhs_unconstrained;
        stats.response_seconds += seconds_since(tr);
      }
    }
    if (d_.handlers.empty() || alpha == 0.0 || pass + 1 >= kMaxContactPasses) break;
    if (!update_active_set(s, dt, alpha, beta, dt_b, pass, bounded, stats)) break;
    ++stats.contact_passes;
  }
  if (bounded_last) release_inactive_bounds(stats);
  if (!d_.contacts.empty()) {
    stats.contacts += static_cast<long>(d_.contacts.size());
    ++stats.contact_solves;
    stats.max_contacts = std::max(stats.max_contacts, static_cast<long>(d_.contacts.size()));
    if (r.converged) d_.history.record(d_.rhs, system_.pinned(), d_.dv);
  }
}

bool Integrator::update_active_set(const State& s, double dt, double alpha, double beta, double dt_b, int pass,
                                   bool bounded, StepStatistics& stats) {
  const int n = system_.num_nodes();
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
  return changed;
}

void Integrator::limit_step_motion(State& s, double alpha) {
  // IntegratorSettings::max_step_motion: dx = dt (v + alpha dv) scaled by f, the end velocity
  // v + dv' with it where alpha is 1 (dv' = f dv - (1 - f) v / alpha keeps dx = dt (v + alpha dv')).
  const double limit = c_.settings.max_step_motion;
  if (!(limit < std::numeric_limits<double>::infinity()) || !(alpha > 0.0)) return;
  double largest2 = 0;
  for (Eigen::Index i = 0; i < s.dx_prev.size(); i += 3)
    largest2 = std::max(largest2, s.dx_prev.segment<3>(i).squaredNorm());
  if (!(largest2 > limit * limit)) return;
  const double f = limit / std::sqrt(largest2);
  s.dx_prev *= f;
  d_.dv = f * d_.dv - ((1 - f) / alpha) * s.v;
}

void Integrator::take_step(State& s, double dt, double alpha, double beta, double dt_b, int newton_iterations) {
  // dx = beta dx_p + dt_b (v + alpha dv), built in dx_prev's storage (no allocation per step);
  // d_.mean_velocity holds the mean velocity dx/dt.
  if (beta != 0.0) {
    s.dx_prev = beta * s.dx_prev + dt_b * (s.v + alpha * d_.dv);
  } else {
    s.dx_prev = dt_b * (s.v + alpha * d_.dv);
    limit_step_motion(s, alpha);
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
}

}  // namespace weft
