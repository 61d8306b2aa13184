#include "linalg/pcg.hpp"

#include <cmath>

namespace weft {

namespace {
void filter(const std::vector<char>& fixed, VecX& v) {
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i]) v.segment<3>(3 * i).setZero();
}
}  // namespace

PcgResult solve_pcg(const BlockMatrix& A, const VecX& b, const std::vector<char>& fixed,
                    const PcgSettings& settings, VecX& x, PcgWorkspace& ws) {
  const int n = A.pattern->num_nodes();
  ws.inverse_diagonal.resize(n);
  for (int i = 0; i < n; ++i) {
    const Mat3& d = A.block[A.pattern->diagonal_slot(i)];
    // The diagonal blocks of an SPD matrix are SPD; fall back to the diagonal if singular.
    Eigen::LLT<Mat3> llt(d);
    if (llt.info() == Eigen::Success) {
      ws.inverse_diagonal[i] = llt.solve(Mat3::Identity());
    } else {
      ws.inverse_diagonal[i] = d.diagonal().cwiseAbs().cwiseMax(1e-300).cwiseInverse().asDiagonal();
    }
  }
  filter(fixed, x);
  VecX bf = b;
  filter(fixed, bf);
  const double bnorm = bf.norm();
  PcgResult result;
  if (bnorm == 0.0) {
    x.setZero();
    result.converged = true;
    return result;
  }
  A.multiply(x, ws.q);
  ws.r = bf - ws.q;
  filter(fixed, ws.r);
  ws.z.resize(3 * n);
  auto precondition = [&](const VecX& r, VecX& z) {
    for (int i = 0; i < n; ++i) node(z, i) = ws.inverse_diagonal[i] * node(r, i);
    filter(fixed, z);
  };
  precondition(ws.r, ws.z);
  ws.p = ws.z;
  double rz = ws.r.dot(ws.z);
  double rnorm = ws.r.norm();
  const double target = settings.relative_tolerance * bnorm;
  int it = 0;
  while (rnorm > target && it < settings.max_iterations) {
    A.multiply(ws.p, ws.q);
    filter(fixed, ws.q);
    const double pq = ws.p.dot(ws.q);
    if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown
    const double a = rz / pq;
    x.noalias() += a * ws.p;
    ws.r.noalias() -= a * ws.q;
    rnorm = ws.r.norm();
    ++it;
    if (rnorm <= target) break;
    precondition(ws.r, ws.z);
    const double rz_new = ws.r.dot(ws.z);
    ws.p = ws.z + (rz_new / rz) * ws.p;
    rz = rz_new;
  }
  result.iterations = it;
  result.relative_residual = rnorm / bnorm;
  result.converged = rnorm <= target;
  return result;
}

}  // namespace weft
