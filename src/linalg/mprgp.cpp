#include "linalg/mprgp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace weft {

namespace {

// The solve's state over the nodes: x, the residual r = b - A x (zero on held nodes), the
// bounds and which of them are active, and the preconditioner in the face (each node's
// diagonal block inverted on its free directions).
class BoundedSolver {
 public:
  BoundedSolver(const BlockMatrix& A, const VecX& b, const std::vector<char>& held, const std::vector<NodeBound>& bounds,
                VecX& x, BoundedSolveWorkspace& ws, std::vector<char>& active)
      : A_(A), b_(b), held_(held), bounds_(bounds), x_(x), ws_(ws), active_(active),
        n_(A.pattern->num_nodes()) {
    const BlockPattern& P = *A.pattern;
    ws_.slot.assign(n_, -1);
    ws_.second.assign(bounds_.size(), -1);
    for (size_t k = 0; k < bounds_.size(); ++k) {
      const int i = bounds_[k].node;
      if (i < 0 || i >= n_) throw std::invalid_argument("solve_bounded: bound on node " + std::to_string(i));
      if (ws_.slot[i] < 0) {
        ws_.slot[i] = static_cast<int>(k);
      } else if (ws_.second[ws_.slot[i]] < 0) {
        ws_.second[ws_.slot[i]] = static_cast<int>(k);
        ws_.second[k] = ws_.slot[i];
      } else {
        throw std::invalid_argument("solve_bounded: more than two bounds on node " + std::to_string(i));
      }
    }
    ws_.scale.assign(n_, 0.0);
    ws_.inverse_free.resize(n_);
    for (int i = 0; i < n_; ++i) {
      const Mat3& d = A.block[P.diagonal_slot(i)];
      ws_.scale[i] = d.trace() / 3;
      ws_.inverse_free[i] = held_[i] ? Mat3::Zero() : invert_spd_block(d);
    }
    // The projected gradient step's length: 1 / (a bound on the largest eigenvalue of
    // C^-1/2 A C^-1/2, C the nodes' mean diagonals; Gershgorin's rows).
    double largest = 0;
    const auto& row_start = P.row_start();
    const auto& column = P.column();
    for (int i = 0; i < n_; ++i) {
      if (held_[i]) continue;
      Vec3 row = Vec3::Zero();
      for (int e = row_start[i]; e < row_start[i + 1]; ++e) {
        const int j = column[e];
        if (held_[j]) continue;
        row += A.block[e].cwiseAbs().rowwise().sum() / std::sqrt(ws_.scale[i] * ws_.scale[j]);
      }
      largest = std::max(largest, row.maxCoeff());
    }
    step_ = largest > 0 ? 1.0 / largest : 0.0;
    active_.assign(bounds_.size(), 0);
  }

  BoundedSolveResult solve(const BoundedSolveSettings& settings) {
    BoundedSolveResult result;
    double bnorm2 = 0;
    for (int i = 0; i < n_; ++i)
      if (!held_[i]) bnorm2 += b_.segment<3>(3 * i).squaredNorm();
    const double bnorm = std::sqrt(bnorm2);
    const double target = settings.relative_tolerance * (bnorm > 0 ? bnorm : 1.0);
    for (size_t k = 0; k < bounds_.size(); ++k) project(k);
    refresh_face();
    residual();
    ++result.iterations;
    double rz = precondition();
    ws_.p = ws_.z;
    for (;;) {
      double chopped_scaled = 0;
      const double kkt = std::sqrt(free_norm2() + chopped_norm2(chopped_scaled));
      result.relative_residual = bnorm > 0 ? kkt / bnorm : kkt;
      if (kkt <= target) {
        result.converged = true;
        break;
      }
      if (result.iterations >= settings.max_iterations) break;
      const double gamma = settings.proportioning;
      if (chopped_scaled > gamma * gamma * rz) {
        // Proportioning: a step along the scaled chopped residual frees the bounds it pulls.
        ws_.d.setZero(3 * n_);
        for (size_t k = 0; k < bounds_.size(); ++k) {
          if (!active_[k]) continue;
          const int i = bounds_[k].node;
          const double along = bounds_[k].normal.dot(ws_.r.segment<3>(3 * i));
          if (along > 0) ws_.d.segment<3>(3 * i) += (along / ws_.scale[i]) * bounds_[k].normal;
        }
        multiply(ws_.d, ws_.q);
        ++result.iterations;
        const double rd = ws_.r.dot(ws_.d), dq = ws_.d.dot(ws_.q);
        if (!(dq > 0)) break;
        const double a = rd / dq;
        x_ += a * ws_.d;
        ws_.r -= a * ws_.q;
        for (size_t k = 0; k < bounds_.size(); ++k) {
          const int i = bounds_[k].node;
          if (active_[k] && bounds_[k].normal.dot(ws_.d.segment<3>(3 * i)) > 0) active_[k] = 0;
        }
        ++result.proportionings;
        refresh_face();
        rz = precondition();
        ws_.p = ws_.z;
        continue;
      }
      multiply(ws_.p, ws_.q);
      ++result.iterations;
      const double pq = ws_.p.dot(ws_.q);
      if (!(pq > 0)) break;
      const double a_cg = rz / pq;
      // The longest step along p that meets no bound.
      double a_feasible = std::numeric_limits<double>::infinity();
      for (size_t k = 0; k < bounds_.size(); ++k) {
        if (active_[k]) continue;
        const NodeBound& c = bounds_[k];
        const double np = c.normal.dot(ws_.p.segment<3>(3 * c.node));
        if (np < 0) a_feasible = std::min(a_feasible, std::max(0.0, c.normal.dot(x_.segment<3>(3 * c.node)) - c.lower) / -np);
      }
      if (a_cg <= a_feasible) {
        x_ += a_cg * ws_.p;
        ws_.r -= a_cg * ws_.q;
        for (size_t k = 0; k < bounds_.size(); ++k)
          if (active_[k]) project(k);
        const double rz_new = precondition();
        ws_.p = ws_.z + (rz_new / rz) * ws_.p;
        rz = rz_new;
        continue;
      }
      // Expansion. To the first bound; from there, first the whole CG step with every bound it
      // crosses met (projected), kept where it lowers the energy: a step that crosses many
      // bounds then meets them all at once, where the projected gradient step below meets a
      // few and CG starts again after each.
      x_ += a_feasible * ws_.p;
      ws_.r -= a_feasible * ws_.q;
      if (settings.projected_cg_step) {
        ws_.x_save = x_;
        ws_.r_save = ws_.r;
        ws_.active_save = active_;
        x_ += (a_cg - a_feasible) * ws_.p;
        for (size_t k = 0; k < bounds_.size(); ++k) project(k);
        residual();
        ++result.iterations;
        // f(x) - f(x_b) = -1/2 d . (r + r_b), d = x - x_b, for f = 1/2 x^T A x - b^T x
        // (d is zero on held nodes, where the residuals are not kept).
        ws_.d = x_ - ws_.x_save;
        if (-0.5 * ws_.d.dot(ws_.r + ws_.r_save) < 0) {
          ++result.expansions;
          refresh_face();
          rz = precondition();
          ws_.p = ws_.z;
          continue;
        }
        x_ = ws_.x_save;
        ws_.r = ws_.r_save;
        active_ = ws_.active_save;
      }
      for (size_t k = 0; k < bounds_.size(); ++k) {
        if (active_[k]) continue;
        const NodeBound& c = bounds_[k];
        if (c.normal.dot(x_.segment<3>(3 * c.node)) <= c.lower) project(k);
      }
      refresh_face();
      free_residual(ws_.d);
      for (int i = 0; i < n_; ++i) ws_.d.segment<3>(3 * i) *= held_[i] ? 0.0 : step_ / ws_.scale[i];
      x_ += ws_.d;
      for (size_t k = 0; k < bounds_.size(); ++k) {
        const NodeBound& c = bounds_[k];
        if (active_[k] || c.normal.dot(x_.segment<3>(3 * c.node)) < c.lower) project(k);
      }
      ++result.expansions;
      refresh_face();
      residual();
      ++result.iterations;
      rz = precondition();
      ws_.p = ws_.z;
    }
    return result;
  }

 private:
  // Puts bound k's node on it and marks it active.
  void project(size_t k) {
    const NodeBound& c = bounds_[k];
    auto xi = x_.segment<3>(3 * c.node);
    if (held_[c.node]) return;
    const double along = c.normal.dot(xi);
    if (active_[k] || along < c.lower) {
      xi += (c.lower - along) * c.normal;
      active_[k] = 1;
    }
  }

  // The projector onto node i's free directions (identity for a node with no active bound).
  Mat3 face(int i) const {
    Mat3 P = Mat3::Identity();
    for (int k = ws_.slot[i]; k >= 0; k = next(k, i))
      if (active_[k]) P -= bounds_[k].normal * bounds_[k].normal.transpose();
    return P;
  }
  int next(int k, int i) const {
    const int other = ws_.second[k];
    return other > k && bounds_[other].node == i ? other : -1;
  }

  // The preconditioner's blocks of the bounded nodes for the active set: the diagonal block
  // restricted to the free directions, (P D P + c (I - P))^-1 (applied between projections
  // onto the face, P).
  void refresh_face() {
    const BlockPattern& P = *A_.pattern;
    for (size_t k = 0; k < bounds_.size(); ++k) {
      const int i = bounds_[k].node;
      if (ws_.slot[i] != static_cast<int>(k) || held_[i]) continue;
      const Mat3 S = face(i);
      const Mat3& d = A_.block[P.diagonal_slot(i)];
      ws_.inverse_free[i] = invert_spd_block(S * d * S + ws_.scale[i] * (Mat3::Identity() - S));
    }
  }

  void multiply(const VecX& v, VecX& y) {
    A_.multiply(v, y);
    for (int i = 0; i < n_; ++i)
      if (held_[i]) y.segment<3>(3 * i).setZero();
  }
  void residual() {
    A_.multiply(x_, ws_.r);
    ws_.r = b_ - ws_.r;
    for (int i = 0; i < n_; ++i)
      if (held_[i]) ws_.r.segment<3>(3 * i).setZero();
  }
  // The residual on the free directions (the active bounds' normal parts removed).
  void free_residual(VecX& out) const {
    out = ws_.r;
    for (size_t k = 0; k < bounds_.size(); ++k)
      if (active_[k]) {
        auto oi = out.segment<3>(3 * bounds_[k].node);
        oi -= bounds_[k].normal.dot(oi) * bounds_[k].normal;
      }
  }
  // |r|^2 on the free directions, node by node (subtracting the active normals' parts from
  // |r|^2 would lose the small free residual under the contact forces' large one).
  double free_norm2() const {
    double s = 0;
    for (int i = 0; i < n_; ++i) {
      s += (ws_.slot[i] >= 0 ? in_face(i, ws_.r.segment<3>(3 * i)) : Vec3(ws_.r.segment<3>(3 * i))).squaredNorm();
    }
    return s;
  }
  // |beta|^2, beta the active bounds' residual that would free them; `scaled` gets
  // sum |beta_i|^2 / c_i.
  double chopped_norm2(double& scaled) const {
    double s = 0;
    scaled = 0;
    for (size_t k = 0; k < bounds_.size(); ++k) {
      if (!active_[k]) continue;
      const int i = bounds_[k].node;
      const double along = bounds_[k].normal.dot(ws_.r.segment<3>(3 * i));
      if (along > 0) {
        s += along * along;
        scaled += along * along / ws_.scale[i];
      }
    }
    return s;
  }
  // Node i's vector without its parts along the active bounds' normals.
  Vec3 in_face(int i, Vec3 v) const {
    for (int k = ws_.slot[i]; k >= 0; k = next(k, i))
      if (active_[k]) v -= bounds_[k].normal.dot(v) * bounds_[k].normal;
    return v;
  }
  // z = M^-1 r in the face; returns r . z. At a node with active bounds the residual is
  // projected before the product and the product after it: the block's rounding would
  // otherwise mix the contact force (the residual's large part along the normals) into z.
  double precondition() {
    ws_.z.resize(3 * n_);
    double rz = 0;
    for (int i = 0; i < n_; ++i) {
      Vec3 ri = ws_.r.segment<3>(3 * i);
      Vec3 zi;
      if (ws_.slot[i] >= 0) {
        ri = in_face(i, ri);
        zi = in_face(i, ws_.inverse_free[i] * ri);
      } else {
        zi = ws_.inverse_free[i] * ri;
      }
      ws_.z.segment<3>(3 * i) = zi;
      rz += zi.dot(ri);
    }
    return rz;
  }

  const BlockMatrix& A_;
  const VecX& b_;
  const std::vector<char>& held_;
  const std::vector<NodeBound>& bounds_;
  VecX& x_;
  BoundedSolveWorkspace& ws_;
  std::vector<char>& active_;
  const int n_;
  double step_ = 0;
};

}  // namespace

BoundedSolveResult solve_bounded(const BlockMatrix& A, const VecX& b, const std::vector<char>& held,
                                 const std::vector<NodeBound>& bounds, const BoundedSolveSettings& settings, VecX& x,
                                 BoundedSolveWorkspace& ws, std::vector<char>& active) {
  BoundedSolver solver(A, b, held, bounds, x, ws, active);
  return solver.solve(settings);
}

}  // namespace weft
