#include "linalg/pcg.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "linalg/cg.hpp"

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

// A Krylov space of the explicit product y = A p on the free nodes and a preconditioner
// z = M^-1 r: inverse diagonal blocks, or one multigrid V-cycle (whose product uses the
// compact lower copy of A it keeps). Vectors are node-ordered, zero on fixed nodes.
class ProductSpace {
 public:
  ProductSpace(const BlockMatrix& A, bool multigrid, double target, VecX& x, PcgWorkspace& ws)
      : A_(A), multigrid_(multigrid), target_(target), x_(x), ws_(ws), size_(x.size()) {}

  /// r = b - A x and z = M^-1 r; returns r . z (rnorm() is |r|).
  double start() {
    multiply(x_, ws_.q);
    ws_.r = ws_.b - ws_.q;
    filter(ws_.fixed_nodes, ws_.r);
    ws_.z.resize(size_);
    ws_.p.setZero(size_);
    rnorm_ = ws_.r.norm();
    return precondition();
  }
  double rnorm() const { return rnorm_; }

  double curvature(double beta) {
    double* pw = ws_.p.data();
    const double* zp = ws_.z.data();
    for (long k = 0; k < size_; ++k) pw[k] = zp[k] + beta * pw[k];
    multiply(ws_.p, ws_.q);
    const double* pp = ws_.p.data();
    const double* qp = ws_.q.data();
    return reduce(size_, [&](long k) { return pp[k] * qp[k]; });
  }

  /// Stops when |r| reaches the target.
  bool advance(double a, double& rz) {
    double* xp = x_.data();
    double* rp = ws_.r.data();
    const double* pp = ws_.p.data();
    const double* qp = ws_.q.data();
    const double rr = reduce(size_, [&](long k) {
      xp[k] += a * pp[k];
      rp[k] -= a * qp[k];
      return rp[k] * rp[k];
    });
    rnorm_ = std::sqrt(rr);
    if (rnorm_ <= target_) return true;
    rz = precondition();
    return false;
  }

 private:
  void multiply(const VecX& v, VecX& y) {
    if (multigrid_) {
      ws_.multigrid.multiply_free(v, y);
    } else {
      A_.multiply(v, y);
      filter(ws_.fixed_nodes, y);
    }
  }
  // z = M^-1 r; returns r . z.
  double precondition() {
    if (multigrid_) {
      ws_.multigrid.apply(ws_.r, ws_.z);  // zero on fixed nodes
      return ws_.z.dot(ws_.r);
    }
    const Mat3* inv = ws_.inverse_diagonal.data();
    double rz = 0;
    for (long i = 0; i < size_ / 3; ++i) {
      const Vec3 zi = inv[i] * ws_.r.segment<3>(3 * i);
      ws_.z.segment<3>(3 * i) = zi;
      rz += zi.dot(ws_.r.segment<3>(3 * i));
    }
    return rz;
  }

  const BlockMatrix& A_;
  const bool multigrid_;
  const double target_;
  VecX& x_;
  PcgWorkspace& ws_;
  const long size_;
  double rnorm_ = 0;
};

// Symmetric block SOR preconditioning with Eisenstat's trick, as a Krylov space. With
// A = L + D + L^T and B = D/w, CG runs on the transformed system
//   A^ = (B + L)^-1 A (B + L^T)^-1,  x^ = (B + L^T) x,  b^ = (B + L)^-1 b,
// which is symmetric positive definite, preconditioned by B (together the SSOR-preconditioned
// CG on A). Since A = (B + L) + (B + L^T) + (D - 2B), a product is
//   A^ p = t + (B + L)^-1 (p + (1 - 2/w) D t),  t = (B + L^T)^-1 p,
// two triangular solves (linalg/ssor.hpp); B t = p - L^T t makes the right-hand side of the
// second (w - 1) p + (2 - w) L^T t, written by the first. x itself is updated with the t's,
// one step late: the next upper solve applies the pending update as t streams by (flush()
// applies it at once). Vectors are in the operator's layout (3 kLanes numbers per group).
//
// The transformed residual r^ = (B + L)^-1 r is not the true one: the space predicts |r| as
// |r^| times a scale (the last known |r| / |r^|) and, when the prediction reaches the target,
//  - in double precision, computes the true residual (one product), stops if it is below the
//    target and otherwise carries on with the scale it found;
//  - in single precision, stops: x is then a correction whose true residual the caller
//    checks in double precision (solve_ssor_single).
template <class T>
class SsorSpace {
 public:
  using Vector = typename SsorOperatorT<T>::Vector;
  SsorSpace(const SsorOperatorT<T>& S, double omega, double target, T* x, Vector& r, Vector& z,
            Vector& p, Vector& q, Vector& t, Vector& w)
      : S_(S), omega_(omega), cp_(omega - 1.0), cu_(2.0 - omega), target_(target), x_(x), r_(r),
        z_(z), p_(p), q_(q), t_(t), w_(w) {}

  /// Starts from the true residual in w (operator layout) of norm rnorm: r^ = (B + L)^-1 r,
  /// z^ = B r^, p = 0. The scale is `ratio` when positive, else rnorm / |r^|. Returns r^ . z^.
  double start(double rnorm, double ratio) {
    S_.solve_lower(w_.data(), r_.data());
    scale_ = ratio > 0 ? ratio : rnorm / std::max<double>(r_.norm(), 1e-300);
    p_.setZero();
    S_.diagonal_times(1.0 / omega_, r_.data(), z_.data());
    checked_at_ = -1;
    rnorm_ = rnorm;
    rnorm_current_ = true;
    if constexpr (std::is_same_v<T, double>) {
      const double* rp = r_.data();
      const double* zp = z_.data();
      return reduce(r_.size(), [&](long k) { return rp[k] * zp[k]; });
    } else {
      return r_.template cast<double>().dot(z_.template cast<double>());
    }
  }

  double curvature(double beta) {
    S_.step_and_solve_upper(z_.data(), beta, p_.data(), t_.data(), w_.data(), cp_, cu_, x_,
                            pending_);
    pending_ = 0.0;
    return S_.solve_lower_dot(w_.data(), q_.data(), p_.data(), t_.data());  // p . (q + t)
  }

  bool advance(double a, double& rz) {
    const double rr = S_.update(a, t_.data(), q_.data(), r_.data(), 1.0 / omega_, z_.data(), rz);
    pending_ = a;
    rnorm_current_ = false;
    const double rh_norm = std::sqrt(rr);
    if (rh_norm * scale_ > target_) return false;
    checked_at_ = rh_norm;
    if constexpr (std::is_same_v<T, double>) {
      flush();
      rnorm_ = true_residual();
      rnorm_current_ = true;
      scale_ = rnorm_ / std::max(rh_norm, 1e-300);
      return rnorm_ <= target_;
    } else {
      return true;
    }
  }

  /// Applies the pending update of x.
  void flush() {
    if (pending_ != 0.0) S_.axpy(pending_, t_.data(), x_);
    pending_ = 0.0;
  }

  /// Double precision: |b - A x| from a product into q (b in the operator's layout).
  void set_rhs(const T* b) { b_ = b; }
  double true_residual() {
    S_.multiply(x_, q_.data());
    const T* bp = b_;
    const T* qp = q_.data();
    return std::sqrt(reduce(r_.size(), [&](long k) { return (bp[k] - qp[k]) * (bp[k] - qp[k]); }));
  }
  /// Double precision: the true |r| at the last check, and whether x has not moved since.
  double rnorm() const { return rnorm_; }
  bool rnorm_current() const { return rnorm_current_; }
  /// |r^| at the last check (-1: none since start) and the scale |r| / |r^| then used.
  double checked_at() const { return checked_at_; }
  double scale() const { return scale_; }

 private:
  const SsorOperatorT<T>& S_;
  const double omega_, cp_, cu_, target_;
  T* x_;
  Vector &r_, &z_, &p_, &q_, &t_, &w_;
  const T* b_ = nullptr;
  double scale_ = 1.0, pending_ = 0.0, rnorm_ = 0.0, checked_at_ = -1;
  bool rnorm_current_ = true;
};

// SSOR-preconditioned CG in double precision (SsorSpace<double>). The scale of the predicted
// residual starts from the one found at the previous solve's last check (the solves of a
// simulation resemble each other; the initial residual's ratio is often far from the ratio
// near convergence), else the initial residual's.
PcgResult solve_ssor(const BlockMatrix& A, const std::vector<char>& fixed, const PcgSettings& settings,
                     double bnorm, VecX& x, PcgWorkspace& ws) {
  const double target = settings.relative_tolerance * bnorm;
  const int free_nodes = static_cast<int>(fixed.size() - ws.fixed_nodes.size());
  const double omega = settings.ssor_omega > 0 ? settings.ssor_omega : ssor_relaxation_for(free_nodes);
  SsorOperator& S = ws.ssor;
  S.assign(A, fixed, omega, settings.node_order, settings.ssor_whole_blocks);
  const long size = S.vector_size();
  S.pad(x, ws.x4);
  S.pad(ws.b, ws.b4);
  for (VecX* v : {&ws.r, &ws.z, &ws.p, &ws.q, &ws.t, &ws.w}) v->resize(size);
  SsorSpace<double> space(S, omega, target, ws.x4.data(), ws.r, ws.z, ws.p, ws.q, ws.t, ws.w);
  space.set_rhs(ws.b4.data());

  double rnorm = space.true_residual();
  int iterations = 0;
  if (rnorm > target) {
    ws.w = ws.b4 - ws.q;  // the true residual, from the product in q
    const double rz = space.start(rnorm, ws.ssor_residual_ratio);
    iterations = conjugate_gradient(space, rz, settings.max_iterations).iterations;
    space.flush();
    if (space.checked_at() >= 0) ws.ssor_residual_ratio = space.scale();
    // Stopped by the iteration cap or a breakdown: the residual of the x reached.
    rnorm = space.rnorm_current() ? space.rnorm() : space.true_residual();
  }
  S.unpad(ws.x4, x);
  PcgResult result;
  result.iterations = iterations;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}

// SSOR-preconditioned CG with the iterations in single precision (SsorSpace<float>): a
// restarting wrapper around runs of conjugate_gradient. x, b and the true residual
// r = b - A x stay in double precision in node order (products with A itself). Each run
// starts from the true residual and accumulates its correction dx in single precision; when
// the predicted residual reaches the run's target, x += dx and the true residual is checked.
// Above the target CG restarts from it (the single-precision recursion has drifted from the
// true residual by then, so continuing would not converge); if the restart did not at least
// halve the true residual since the previous check, or the curvature broke down, the solve
// finishes in double precision (solve_ssor) from the x reached, with the iterations left
// under the cap.
PcgResult solve_ssor_single(const BlockMatrix& A, const std::vector<char>& fixed, const PcgSettings& settings,
                            double bnorm, VecX& x, PcgWorkspace& ws) {
  const double target = settings.relative_tolerance * bnorm;
  const int free_nodes = static_cast<int>(fixed.size() - ws.fixed_nodes.size());
  const double omega = settings.ssor_omega > 0 ? settings.ssor_omega : ssor_relaxation_for(free_nodes);
  SsorOperatorT<float>& S = ws.ssor_single;
  S.assign(A, fixed, omega, settings.node_order, settings.ssor_whole_blocks);
  const long size = S.vector_size();
  for (Eigen::VectorXf* v : {&ws.fr, &ws.fz, &ws.fp, &ws.fq, &ws.ft, &ws.fw, &ws.fdx}) v->resize(size);
  auto true_residual = [&]() {
    A.multiply(x, ws.residual);
    ws.residual = ws.b - ws.residual;
    filter(ws.fixed_nodes, ws.residual);
    return ws.residual.norm();
  };
  PcgResult result;
  double rnorm = true_residual();
  int it = 0;
  constexpr double kRunReduction = 1e-6;
  while (rnorm > target && it < settings.max_iterations) {
    // A run aims at most kRunReduction below its start: beyond, the single-precision recursion
    // keeps shrinking while the true residual it stands for no longer does.
    const double run_start = rnorm;
    const double run_target = std::max(target, kRunReduction * run_start);
    SsorSpace<float> space(S, omega, run_target, ws.fdx.data(), ws.fr, ws.fz, ws.fp, ws.fq, ws.ft,
                           ws.fw);
    S.pad(ws.residual, ws.fw);
    ws.fdx.setZero();
    // A restart (it > 0) takes its scale from its own true residual.
    const double rz = space.start(rnorm, it == 0 ? ws.ssor_residual_ratio : 0.0);
    const CgRun run = conjugate_gradient(space, rz, settings.max_iterations - it);
    it += run.iterations;
    // What the run reached (at its check, the iteration cap or a breakdown) goes into x.
    space.flush();
    S.unpad(ws.fdx, ws.correction);
    x += ws.correction;
    rnorm = true_residual();
    if (rnorm <= target || it >= settings.max_iterations) break;
    if (run.breakdown || !(rnorm < 0.5 * run_start)) {
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
  // The next solve's first run takes its scale from this solve's last residual: the ratio
  // |r| / |(B + L)^-1 r| of the true residual, one lower solve. Not from the run's own
  // recursion: a run that goes on below single precision's reach shrinks |r^| while |r| stays,
  // and such a ratio would make the next solve aim deeper still, a feedback that ends in a
  // solve that never checks and does not converge.
  if (it > 0 && rnorm > 0) {
    S.pad(ws.residual, ws.fw);
    S.solve_lower(ws.fw.data(), ws.fr.data());
    const double rh = ws.fr.template cast<double>().norm();
    if (rh > 0 && std::isfinite(rh)) ws.ssor_residual_ratio = rnorm / rh;
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
  const double target = settings.relative_tolerance * bnorm;
  ProductSpace space(A, multigrid, target, x, ws);
  const double rz = space.start();
  int it = 0;
  if (space.rnorm() > target) it = conjugate_gradient(space, rz, settings.max_iterations).iterations;
  const double rnorm = space.rnorm();
  result.iterations = it;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}

}  // namespace weft
