#pragma once
// The analytic colliders' surfaces as triangles, drawn for the output frames and checks
// (Collider::surface).
#include <vector>

#include "weft/collider.hpp"

namespace weft {

/// A unit vector normal to `axis` (itself unit).
Vec3 any_unit_normal_to(const Vec3& axis);

/// Adds a latitude-longitude sphere of `radius` about `centre`, its upper half (y >= 0 in the
/// frame R) shifted by `stretch` (a capsule's axis), to positions and triangles.
void add_round_surface(const Vec3& centre, double radius, const Mat3& R, const Vec3& stretch,
                       std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris);

/// Adds the box's surface (shape box of `s`, wound outwards, its rounded edges drawn as
/// chords) to positions and triangles.
void add_box_surface(const ColliderSpec& s, std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris);

}  // namespace weft
