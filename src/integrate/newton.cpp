// Newton iterations on the step's nonlinear equations (docs/method.md), taken where the
// linearised step's error is large.
#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>

#include "util/timer.hpp"

namespace weft {

double Integrator::newton_residual(const State& s, double alpha, double beta, double dt_b, const VecX& dv,
                                   VecX& r) {
  d_.newton_v = s.v + alpha * dv;
  d_.newton_x = s.x + (alpha * dt_b) * d_.newton_v;
  if (beta != 0.0) d_.newton_x += (alpha * beta) * s.dx_prev;
  system_.evaluate(d_.newton_x, d_.newton_v, false, d_.eval);
  r = dt_b * d_.eval.force - c_.mass3.cwiseProduct(dv);
  if (beta != 0.0) r += beta * c_.mass3.cwiseProduct(s.dv_prev);
  const auto& pinned = system_.pinned();
  for (size_t i = 0; i < pinned.size(); ++i)
    if (pinned[i]) r.segment<3>(3 * i).setZero();
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
        filter_matrix(d_.newton_step.matrix);
        d_.newton_rhs = d_.newton_r;
        for (size_t k = 0; k < d_.contacts.size(); ++k) {
          const int i = d_.contacts[k].node;
          node(d_.newton_rhs, i) = contact_filter(k) * node(d_.newton_rhs, i);
        }
        rhs = &d_.newton_rhs;
      }
      d_.newton_delta.setZero(3 * n);
      const PcgResult r =
          solve_pcg(d_.newton_step.matrix, *rhs, system_.pinned(), pcg_settings(), d_.newton_delta, d_.pcg);
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

}  // namespace weft
