#pragma once
// The conjugate gradient iteration, written once for every preconditioner (linalg/pcg.cpp).
//
// A preconditioned CG run is the same recurrence whatever the preconditioner: from r . z of
// the starting residual r and its preconditioned z = M^-1 r, with the direction p = 0,
//   p = z + beta p,  q = A p,  a = r.z / p.q,  x += a p,  r -= a q,  z = M^-1 r,
//   beta = r.z(new) / r.z.
// What differs is how the pieces are computed and fused (a product and a preconditioner
// application, or the two triangular solves of Eisenstat's SSOR on a transformed system),
// the vectors' layout and when to stop. A *Krylov space* supplies those pieces:
//
//   double curvature(double beta)       p = z + beta p, then q = A p; returns p . q
//   bool advance(double a, double& rz)  x += a p, r -= a q (a space may defer x's update);
//                                       true when the space's stopping rule is met, else
//                                       z = M^-1 r and rz = r . z
//
// and conjugate_gradient runs the recurrence on it.

namespace weft {

/// How a run of conjugate_gradient ended.
struct CgRun {
  int iterations = 0;
  /// The curvature along a direction was not positive (loss of positive definiteness, or
  /// a zero direction): the run stopped before updating x along it.
  bool breakdown = false;
};

/// Runs CG on `space` from r . z = rz (the space's direction p must hold zeros) until the
/// space's stopping rule is met, the curvature breaks down, or max_iterations iterations.
template <class Space>
CgRun conjugate_gradient(Space& space, double rz, int max_iterations) {
  CgRun run;
  double beta = 0.0;
  while (run.iterations < max_iterations) {
    const double pq = space.curvature(beta);
    if (!(pq > 0.0)) {
      run.breakdown = true;
      break;
    }
    double rz_new = 0.0;
    const bool done = space.advance(rz / pq, rz_new);
    ++run.iterations;
    if (done) break;
    beta = rz_new / rz;
    rz = rz_new;
  }
  return run;
}

}  // namespace weft
