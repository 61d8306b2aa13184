// After the solve: the contact handlers' fail-safes and prescribed motions, with the energy
// they change booked as their work.
#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>

#include "util/timer.hpp"

namespace weft {

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
      (c_.settings.method == Method::kAlphaFamily || c_.settings.method == Method::kBdf2) && c_.settings.alpha > 0.0) {
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

}  // namespace weft
