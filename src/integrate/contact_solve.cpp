// Contacts in the step's solve: the active set's filters (constrain, unconstrain), contacts
// as bounds (bounded_pass), the constraint impulses and the velocities contacts leave.
#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>

#include "util/timer.hpp"

namespace weft {

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

void Integrator::filter_matrix(BlockMatrix& matrix) const {
  filter_matrix(matrix, [](int) {});
}

void Integrator::unconstrain(double dt, double dt_b) {
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
  d_.bound_held = system_.pinned();
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

}  // namespace weft
