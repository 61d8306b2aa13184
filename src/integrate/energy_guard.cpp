// The energy guard (docs/guarded-midpoint.md): a step that would put energy in is taken again
// as halves, then with a larger alpha; backward Euler's halving likewise.
#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "util/timer.hpp"

namespace weft {

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
  if (c_.settings.method == Method::kAlphaFamily && fail_safe > kGuardFailSafeShare * scale) gain += fail_safe;
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

}  // namespace weft
