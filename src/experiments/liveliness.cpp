#include "weft/experiments/liveliness.hpp"

#include <algorithm>
#include <limits>
#include <map>

namespace weft {

RigidVelocity fit_rigid_velocity(const Points& positions, const Points& velocities) {
  RigidVelocity r;
  const Eigen::Index n = positions.rows();
  if (n == 0) return r;
  r.centre = positions.colwise().mean().transpose();
  r.linear = velocities.colwise().mean().transpose();
  // Minimising sum |v_i - V - w x r_i|^2 over w: I w = sum r_i x (v_i - V), with
  // I = sum (|r_i|^2 Id - r_i r_i^T) the points' inertia about the centre.
  Mat3 inertia = Mat3::Zero();
  Vec3 moment = Vec3::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 ri = positions.row(i).transpose() - r.centre;
    inertia += ri.squaredNorm() * Mat3::Identity() - ri * ri.transpose();
    moment += ri.cross(velocities.row(i).transpose() - r.linear);
  }
  // In the range of the inertia: about a line of points the spin about it is undetermined.
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  for (int k = 0; k < 3; ++k) {
    const double lambda = eig.eigenvalues()[k];
    if (!(lambda > 1e-12 * largest)) continue;
    const Vec3 e = eig.eigenvectors().col(k);
    r.angular += (e.dot(moment) / lambda) * e;
  }
  return r;
}

double relative_kinetic_energy(const VecX& x, const VecX& v, const VecX& mass, const RigidVelocity& body) {
  double energy = 0;
  for (Eigen::Index i = 0; i < mass.size(); ++i) {
    const Vec3 u = v.segment<3>(3 * i) - body.at(x.segment<3>(3 * i));
    energy += 0.5 * mass[i] * u.squaredNorm();
  }
  return energy;
}

std::vector<int> lowest_boundary_loop(const std::vector<std::array<int, 3>>& triangles, const VecX& x) {
  // Boundary edges: those of one triangle, directed as in it.
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) ++uses[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::map<int, std::vector<int>> next;
  for (const auto& [edge, count] : uses)
    if (count == 1) {
      next[edge.first].push_back(edge.second);
      next[edge.second].push_back(edge.first);
    }
  // Connected components of the boundary graph (loops; a vertex where loops touch joins them).
  std::map<int, int> component;
  std::vector<std::vector<int>> loops;
  for (const auto& [start, _] : next) {
    if (component.count(start)) continue;
    std::vector<int> loop, stack{start};
    component[start] = static_cast<int>(loops.size());
    while (!stack.empty()) {
      const int a = stack.back();
      stack.pop_back();
      loop.push_back(a);
      for (int b : next[a])
        if (!component.count(b)) {
          component[b] = static_cast<int>(loops.size());
          stack.push_back(b);
        }
    }
    std::sort(loop.begin(), loop.end());
    loops.push_back(std::move(loop));
  }
  std::vector<int> best;
  double lowest = std::numeric_limits<double>::infinity();
  for (auto& loop : loops) {
    const double y = mean_of(x, loop).y();
    if (y < lowest) {
      lowest = y;
      best = loop;
    }
  }
  return best;
}

Vec3 mean_of(const VecX& x, const std::vector<int>& vertices) {
  Vec3 sum = Vec3::Zero();
  for (int i : vertices) sum += x.segment<3>(3 * i);
  return vertices.empty() ? sum : Vec3(sum / static_cast<double>(vertices.size()));
}

double swing_amplitude(const std::vector<Vec3>& offsets, const Vec3& direction) {
  if (offsets.size() < 2 || direction.norm() == 0) return 0.0;
  const Vec3 d = direction.normalized();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& o : offsets) {
    lo = std::min(lo, o.dot(d));
    hi = std::max(hi, o.dot(d));
  }
  return 0.5 * (hi - lo);
}

}  // namespace weft
