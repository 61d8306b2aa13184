#pragma once
// How lively a garment moves on a body (docs/walk.md): its kinetic energy relative to the
// body's rigid motion, the swing of its hem, and its distance from a reference run.
#include <array>
#include <vector>

#include "weft/body.hpp"

namespace weft {

/// The rigid motion that best fits a set of point velocities: v(p) ~ linear + angular x (p - centre),
/// by least squares with equal weights (centre: the points' mean).
struct RigidVelocity {
  Vec3 centre = Vec3::Zero(), linear = Vec3::Zero(), angular = Vec3::Zero();
  Vec3 at(const Vec3& p) const { return linear + angular.cross(p - centre); }
};
/// Fits positions (#V x 3) and velocities (#V x 3). Fewer than 3 points, or points on a line:
/// the angular part solved in the range of the inertia (the part about the line is 0).
RigidVelocity fit_rigid_velocity(const Points& positions, const Points& velocities);

/// Kinetic energy of the cloth (3n vectors x, v and n masses) relative to the rigid motion
/// `body`: sum_i m_i |v_i - body.at(x_i)|^2 / 2 (J). 0 for a cloth moving with it rigidly.
double relative_kinetic_energy(const VecX& x, const VecX& v, const VecX& mass, const RigidVelocity& body);

/// The vertices of the boundary loop (edges with one triangle) whose mean height (y) at
/// `x` is lowest: a garment's hem. Empty for a closed mesh.
std::vector<int> lowest_boundary_loop(const std::vector<std::array<int, 3>>& triangles, const VecX& x);

/// Mean of the listed vertices of a 3n vector.
Vec3 mean_of(const VecX& x, const std::vector<int>& vertices);

/// Half the range (max - min) of the offsets projected on `direction` (normalised): the
/// amplitude of a swing along it. 0 for fewer than two offsets.
double swing_amplitude(const std::vector<Vec3>& offsets, const Vec3& direction);

}  // namespace weft
