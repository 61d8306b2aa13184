// Explicit steps: the classical Runge-Kutta method and the embedded Runge-Kutta 4(5) pair.
#include "integrate/integrator.hpp"

#include <algorithm>
#include <cmath>

#include "util/timer.hpp"

namespace weft {

void Integrator::derivative(const VecX& x, const VecX& v, VecX& a, double& viscous_power) {
  system_.evaluate(x, v, false, d_.eval);
  a = d_.eval.force.cwiseQuotient(c_.mass3);
  const auto& pinned = system_.pinned();
  for (size_t i = 0; i < pinned.size(); ++i)
    if (pinned[i]) a.segment<3>(3 * i).setZero();
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
