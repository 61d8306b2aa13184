#include "collision/clamps.hpp"

#include <stdexcept>

namespace weft {

namespace {
// Half the interval of the central difference that gives a motion's velocity (s): keyframed
// motions are piecewise smooth, and 1e-6 s keeps the rounding near 1e-10 m/s.
constexpr double kVelocityStep = 1e-6;
// A vertex found further than this from its path (m) counts as moved by the fail-safe (the
// integrator then books the change of energy): the solve's tolerance leaves less.
constexpr double kOffPath = 1e-6;
}  // namespace

Clamps::Clamps(std::vector<std::vector<int>> groups, std::vector<RigidMotion> motions, const VecX& rest_positions,
               const VecX& mass)
    : groups_(std::move(groups)), motions_(std::move(motions)), rest_(rest_positions), mass_(mass) {
  const Eigen::Index n = mass.size();
  if (groups_.size() != motions_.size() || rest_positions.size() != 3 * n)
    throw std::invalid_argument("Clamps: groups, motions, positions and masses of different sizes");
  clamped_.assign(static_cast<size_t>(n), 0);
  for (const auto& g : groups_)
    for (int i : g) {
      if (i < 0 || i >= n) throw std::invalid_argument("Clamps: a vertex is out of range");
      clamped_[i] = 1;
    }
}

Vec3 Clamps::position(size_t k, int i, double t) const { return motions_[k].at(t) * Vec3(node(rest_, i)); }

Vec3 Clamps::velocity(size_t k, int i, double t) const {
  const Vec3 p = node(rest_, i);
  return (motions_[k].at(t + kVelocityStep) * p - motions_[k].at(t - kVelocityStep) * p) / (2 * kVelocityStep);
}

void Clamps::detect(const VecX& x, const VecX& /*v*/, double t, double dt, std::vector<NodeContact>& out) {
  for (size_t k = 0; k < groups_.size(); ++k)
    for (int i : groups_[k]) {
      NodeContact c;
      c.node = i;
      c.kinematic = true;
      c.displacement = position(k, i, t + dt) - node(x, i);
      c.surface_velocity = velocity(k, i, t + dt);
      c.friction = 0;
      out.push_back(c);
    }
}

void Clamps::finish_step(const VecX& /*x0*/, VecX& x1, VecX& v1, double t, double dt, ContactReport& report) {
  // The solve leaves the vertices on their paths to its tolerance, and explicit methods (no
  // constraints in their steps) not at all: the path is exact here.
  for (size_t k = 0; k < groups_.size(); ++k)
    for (int i : groups_[k]) {
      const Vec3 v_old = node(v1, i);
      const Vec3 on_path = position(k, i, t + dt);
      if ((on_path - node(x1, i)).norm() > kOffPath) ++report.fail_safe_moves;
      node(x1, i) = on_path;
      node(v1, i) = velocity(k, i, t + dt);
      report.work += 0.5 * mass_[i] * (node(v1, i).squaredNorm() - v_old.squaredNorm());
    }
}

}  // namespace weft
