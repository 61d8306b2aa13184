#include "linalg/pcg.hpp"

#include <cmath>

namespace weft {

namespace {
void filter(const std::vector<int>& fixed_nodes, VecX& v) {
  for (int i : fixed_nodes) v.segment<3>(3 * i).setZero();
}
}  // namespace

PcgResult solve_pcg(const BlockMatrix& A, const VecX& b, const std::vector<char>& fixed,
                    const PcgSettings& settings, VecX& x, PcgWorkspace& ws) {
  const int n = A.pattern->num_nodes();
  ws.fixed_nodes.clear();
  for (int i = 0; i < n; ++i)
    if (fixed[i]) ws.fixed_nodes.push_back(i);
  const bool multigrid = settings.preconditioner == Preconditioner::kMultigrid;
  if (multigrid) {
    if (!ws.multigrid.matches(*A.pattern, fixed, settings.multigrid))
      ws.multigrid.setup(A, fixed, settings.multigrid);
    ws.multigrid.update(A);
  } else {
    ws.inverse_diagonal.resize(n);
    for (int i = 0; i < n; ++i) {
      if (fixed[i]) {
        ws.inverse_diagonal[i].setZero();  // keeps the preconditioned vector zero there
        continue;
      }
      const Mat3& d = A.block[A.pattern->diagonal_slot(i)];
      // The diagonal blocks of an SPD matrix are SPD; fall back to the diagonal if singular.
      const double det = d.determinant();
      if (det > 0 && std::isfinite(det)) {
        ws.inverse_diagonal[i] = d.inverse();
      } else {
        ws.inverse_diagonal[i] =
            d.diagonal().cwiseAbs().cwiseMax(1e-300).cwiseInverse().asDiagonal();
      }
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
    const double pq = ws.p.dot(ws.q);
    if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown
    const double a = rz / pq;
    double rr = 0;
    double* xp = x.data();
    double* rp = ws.r.data();
    const double* pp = ws.p.data();
    const double* qp = ws.q.data();
    for (long k = 0; k < size; ++k) {
      xp[k] += a * pp[k];
      rp[k] -= a * qp[k];
      rr += rp[k] * rp[k];
    }
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
