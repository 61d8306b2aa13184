#include "linalg/pcg.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace weft {

namespace {
void filter(const std::vector<int>& fixed_nodes, VecX& v) {
  for (int i : fixed_nodes) v.segment<3>(3 * i).setZero();
}

// sum_k term(k) for k < size, where term may also update vectors at k. Four partial sums
// keep the loop from waiting on one chain of additions (and let it vectorize).
template <class Term>
inline double reduce(long size, Term term) {
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  long k = 0;
  for (; k + 4 <= size; k += 4) {
    s0 += term(k);
    s1 += term(k + 1);
    s2 += term(k + 2);
    s3 += term(k + 3);
  }
  for (; k < size; ++k) s0 += term(k);
  return (s0 + s1) + (s2 + s3);
}

// Symmetric block SOR preconditioning with Eisenstat's trick. With A = L + D + L^T and
// B = D/w, CG runs on the transformed system
//   A^ = (B + L)^-1 A (B + L^T)^-1,  x^ = (B + L^T) x,  b^ = (B + L)^-1 b,
// which is symmetric positive definite, preconditioned by B (together the SSOR-preconditioned
// CG on A). Since A = (B + L) + (B + L^T) + (D - 2B), a product is
//   A^ p = t + (B + L)^-1 (p + (1 - 2/w) D t),  t = (B + L^T)^-1 p,
// two triangular solves (linalg/ssor.hpp); B t = p - L^T t makes the right-hand side of the
// second (w - 1) p + (2 - w) L^T t, written by the first. x itself is updated with the t's.
// The transformed residual r^ = (B + L)^-1 r is not the true one, so the true residual is
// computed (one product) whenever |r^| scaled by the last known |r| / |r^| reaches the
// target, and CG stops only when the true |r| does. The ratio starts from the one found at
// the previous solve's last check (the solves of a simulation resemble each other; the
// initial residual's ratio is often far from the ratio near convergence), else the initial
// residual's. Vectors are in the operator's layout (12 doubles per group of four nodes).
PcgResult solve_ssor(const BlockMatrix& A, const std::vector<char>& fixed, const PcgSettings& settings,
                     double bnorm, VecX& x, PcgWorkspace& ws) {
  const double target = settings.relative_tolerance * bnorm;
  const int free_nodes = static_cast<int>(fixed.size() - ws.fixed_nodes.size());
  const double omega = settings.ssor_omega > 0 ? settings.ssor_omega : ssor_relaxation_for(free_nodes);
  SsorOperator& S = ws.ssor;
  S.assign(A, fixed, omega, settings.node_order, settings.ssor_whole_blocks);
  const long size = S.vector_size();
  VecX& x4 = ws.x4;
  VecX& b4 = ws.b4;
  S.pad(x, x4);
  S.pad(ws.b, b4);
  for (VecX* v : {&ws.r, &ws.z, &ws.p, &ws.q, &ws.t, &ws.w}) v->resize(size);
  double* xp = x4.data();
  const double* bp = b4.data();
  double* rp = ws.r.data();
  double* pp = ws.p.data();
  double* qp = ws.q.data();
  double* tp = ws.t.data();
  double* wp = ws.w.data();
  double* zp = ws.z.data();
  // |b - A x| from a product into q.
  auto true_residual = [&]() {
    S.multiply(xp, qp);
    return std::sqrt(reduce(size, [&](long k) { return (bp[k] - qp[k]) * (bp[k] - qp[k]); }));
  };

  PcgResult result;
  double rnorm = true_residual();
  int it = 0;
  bool rnorm_current = true;  // rnorm is the residual of the current x
  if (rnorm > target) {
    for (long k = 0; k < size; ++k) wp[k] = bp[k] - qp[k];
    S.solve_lower(wp, rp);  // r^
    double scale = ws.ssor_residual_ratio > 0 ? ws.ssor_residual_ratio
                                              : rnorm / std::max(ws.r.norm(), 1e-300);
    ws.p.setZero();
    S.diagonal_times(1.0 / omega, rp, zp);  // z^ = B r^
    double rz = reduce(size, [&](long k) { return rp[k] * zp[k]; });
    double beta = 0.0;
    const double cp = omega - 1.0, cu = 2.0 - omega;
    // x lags behind by pending t: the next upper solve applies it as t streams by, or axpy
    // before a residual check and at the end.
    double pending = 0.0;
    while (it < settings.max_iterations) {
      S.step_and_solve_upper(zp, beta, pp, tp, wp, cp, cu, xp, pending);  // p = z^ + beta p first
      pending = 0.0;
      const double pq = S.solve_lower_dot(wp, qp, pp, tp);  // p . (q + t), the curvature along p
      if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown
      double rz_new;
      const double a = rz / pq;
      const double rr = S.update(a, tp, qp, rp, 1.0 / omega, zp, rz_new);
      pending = a;
      ++it;
      rnorm_current = false;
      const double rh_norm = std::sqrt(rr);
      if (rh_norm * scale <= target) {
        S.axpy(pending, tp, xp);
        pending = 0.0;
        rnorm = true_residual();
        rnorm_current = true;
        scale = rnorm / std::max(rh_norm, 1e-300);
        ws.ssor_residual_ratio = scale;
        if (rnorm <= target) break;
      }
      beta = rz_new / rz;
      rz = rz_new;
    }
    if (pending != 0.0) S.axpy(pending, tp, xp);
  }
  if (!rnorm_current) rnorm = true_residual();  // stopped by the iteration cap or a breakdown
  S.unpad(x4, x);
  result.iterations = it;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}

// solve_ssor's iterations in single precision (SsorOperatorT<float>): x, b and the true
// residual r = b - A x stay in double precision in node order (products with A itself). Each
// run of iterations starts from the true residual and accumulates its correction dx in single
// precision; when the predicted residual reaches the target, x += dx and the true residual is
// checked. Above the target CG restarts from it (the single-precision recursion has drifted
// from the true residual by then, so continuing would not converge); if the restart did not
// at least halve the true residual since the previous check, or the curvature breaks down,
// the solve finishes in double precision (solve_ssor) from the x reached, with the
// iterations left under the cap.
PcgResult solve_ssor_single(const BlockMatrix& A, const std::vector<char>& fixed, const PcgSettings& settings,
                            double bnorm, VecX& x, PcgWorkspace& ws) {
  const double target = settings.relative_tolerance * bnorm;
  const int free_nodes = static_cast<int>(fixed.size() - ws.fixed_nodes.size());
  const double omega = settings.ssor_omega > 0 ? settings.ssor_omega : ssor_relaxation_for(free_nodes);
  SsorOperatorT<float>& S = ws.ssor_single;
  S.assign(A, fixed, omega, settings.node_order, settings.ssor_whole_blocks);
  const long size = S.vector_size();
  for (Eigen::VectorXf* v : {&ws.fr, &ws.fz, &ws.fp, &ws.fq, &ws.ft, &ws.fw, &ws.fdx}) v->resize(size);
  float* rp = ws.fr.data();
  float* zp = ws.fz.data();
  float* pp = ws.fp.data();
  float* qp = ws.fq.data();
  float* tp = ws.ft.data();
  float* wp = ws.fw.data();
  float* dxp = ws.fdx.data();
  auto true_residual = [&]() {
    A.multiply(x, ws.residual);
    ws.residual = ws.b - ws.residual;
    filter(ws.fixed_nodes, ws.residual);
    return ws.residual.norm();
  };
  PcgResult result;
  double rnorm = true_residual();
  int it = 0;
  const double cp = omega - 1.0, cu = 2.0 - omega;
  constexpr double kRunReduction = 1e-6;
  while (rnorm > target && it < settings.max_iterations) {
    // A run of iterations from the true residual: r^ = (B + L)^-1 r, dx = 0.
    S.pad(ws.residual, ws.fw);
    S.solve_lower(wp, rp);
    const double scale = ws.ssor_residual_ratio > 0 ? ws.ssor_residual_ratio
                                                    : rnorm / std::max<double>(ws.fr.norm(), 1e-300);
    ws.fp.setZero();
    ws.fdx.setZero();
    S.diagonal_times(1.0 / omega, rp, zp);
    double rz = ws.fr.cast<double>().dot(ws.fz.cast<double>());
    double beta = 0.0, pending = 0.0;
    double checked_at = -1;  // |r^| where the predicted residual reached the run's target
    bool breakdown = false;
    const double run_start = rnorm;
    // A run aims at most kRunReduction below its start: beyond, the single-precision recursion
    // keeps shrinking while the true residual it stands for no longer does.
    const double run_target = std::max(target, kRunReduction * run_start);
    while (it < settings.max_iterations) {
      S.step_and_solve_upper(zp, beta, pp, tp, wp, cp, cu, dxp, pending);
      pending = 0.0;
      const double pq = S.solve_lower_dot(wp, qp, pp, tp);
      if (!(pq > 0.0)) {
        breakdown = true;
        break;
      }
      double rz_new;
      const double a = rz / pq;
      const double rr = S.update(a, tp, qp, rp, 1.0 / omega, zp, rz_new);
      pending = a;
      ++it;
      const double rh_norm = std::sqrt(rr);
      if (rh_norm * scale <= run_target) {
        checked_at = rh_norm;
        break;
      }
      beta = rz_new / rz;
      rz = rz_new;
    }
    // What the run reached (at its check, the iteration cap or a breakdown) goes into x.
    if (pending != 0.0) S.axpy(pending, tp, dxp);
    S.unpad(ws.fdx, ws.correction);
    x += ws.correction;
    rnorm = true_residual();
    if (checked_at >= 0) ws.ssor_residual_ratio = rnorm / std::max(checked_at, 1e-300);
    if (rnorm <= target || it >= settings.max_iterations) break;
    if (breakdown || !(rnorm < 0.5 * run_start)) {
      ++ws.ssor_single_fallbacks;
      PcgSettings rest_settings = settings;  // the iterations left under the cap
      rest_settings.max_iterations = settings.max_iterations - it;
      const PcgResult rest = solve_ssor(A, fixed, rest_settings, bnorm, x, ws);
      result.iterations = it + rest.iterations;
      result.relative_residual = rest.relative_residual;
      result.converged = rest.converged;
      return result;
    }
  }
  result.iterations = it;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}
}  // namespace

double ssor_relaxation_for(int free_nodes) {
  return 2.0 / (1.0 + 3.5 / std::sqrt(std::sqrt(std::max(free_nodes, 1))));
}

PcgResult solve_pcg(const BlockMatrix& A, const VecX& b, const std::vector<char>& fixed,
                    const PcgSettings& settings, VecX& x, PcgWorkspace& ws) {
  const int n = A.pattern->num_nodes();
  ws.fixed_nodes.clear();
  for (int i = 0; i < n; ++i)
    if (fixed[i]) ws.fixed_nodes.push_back(i);
  if (settings.preconditioner == Preconditioner::kSsor && settings.ssor_omega != 0.0 &&
      !(settings.ssor_omega > 0 && settings.ssor_omega < 2))
    throw std::invalid_argument("SSOR relaxation must be in (0, 2) (or 0 for automatic), got " +
                                std::to_string(settings.ssor_omega));
  const bool multigrid = settings.preconditioner == Preconditioner::kMultigrid;
  if (multigrid) {
    if (!ws.multigrid.matches(*A.pattern, fixed, settings.multigrid))
      ws.multigrid.setup(A, fixed, settings.multigrid);
    ws.multigrid.update(A);
  } else if (settings.preconditioner == Preconditioner::kBlockJacobi) {
    ws.inverse_diagonal.resize(n);
    for (int i = 0; i < n; ++i) {
      if (fixed[i]) {
        ws.inverse_diagonal[i].setZero();  // keeps the preconditioned vector zero there
        continue;
      }
      ws.inverse_diagonal[i] = invert_spd_block(A.block[A.pattern->diagonal_slot(i)]);
    }
  }
  filter(ws.fixed_nodes, x);
  ws.b = b;
  filter(ws.fixed_nodes, ws.b);
  const double bnorm = ws.b.norm();
  PcgResult result;
  if (bnorm == 0.0) {
    x.setZero();
    result.converged = true;
    return result;
  }
  if (settings.preconditioner == Preconditioner::kSsor) {
    result = settings.ssor_single_precision ? solve_ssor_single(A, fixed, settings, bnorm, x, ws)
                                            : solve_ssor(A, fixed, settings, bnorm, x, ws);
    return result;
  }
  // y = A x on the free nodes; with multigrid from the half of A in its compact lower copy.
  auto multiply = [&](const VecX& v, VecX& y) {
    if (multigrid) {
      ws.multigrid.multiply_free(v, y);
    } else {
      A.multiply(v, y);
      filter(ws.fixed_nodes, y);
    }
  };
  multiply(x, ws.q);
  ws.r = ws.b - ws.q;
  filter(ws.fixed_nodes, ws.r);
  ws.z.resize(3 * n);
  const Mat3* inv = ws.inverse_diagonal.data();
  // z = P^-1 r on free nodes; returns r . z.
  auto precondition = [&](const VecX& r, VecX& z) {
    if (multigrid) {
      ws.multigrid.apply(r, z);  // zero on fixed nodes
      return z.dot(r);
    }
    double rz = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3 zi = inv[i] * r.segment<3>(3 * i);
      z.segment<3>(3 * i) = zi;
      rz += zi.dot(r.segment<3>(3 * i));
    }
    return rz;
  };
  double rz = precondition(ws.r, ws.z);
  ws.p = ws.z;
  double rnorm = ws.r.norm();
  const double target = settings.relative_tolerance * bnorm;
  int it = 0;
  const long size = 3L * n;
  while (rnorm > target && it < settings.max_iterations) {
    multiply(ws.p, ws.q);
    const double* pq_p = ws.p.data();
    const double* pq_q = ws.q.data();
    const double pq = reduce(size, [&](long k) { return pq_p[k] * pq_q[k]; });
    if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown
    const double a = rz / pq;
    double* xp = x.data();
    double* rp = ws.r.data();
    const double* pp = ws.p.data();
    const double* qp = ws.q.data();
    const double rr = reduce(size, [&](long k) {
      xp[k] += a * pp[k];
      rp[k] -= a * qp[k];
      return rp[k] * rp[k];
    });
    rnorm = std::sqrt(rr);
    ++it;
    if (rnorm <= target) break;
    const double rz_new = precondition(ws.r, ws.z);
    const double beta = rz_new / rz;
    double* pw = ws.p.data();
    const double* zp = ws.z.data();
    for (long k = 0; k < size; ++k) pw[k] = zp[k] + beta * pw[k];
    rz = rz_new;
  }
  result.iterations = it;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}

}  // namespace weft
