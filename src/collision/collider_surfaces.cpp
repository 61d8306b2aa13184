#include "collision/collider_surfaces.hpp"

#include <array>
#include <cmath>

namespace weft {

Vec3 any_unit_normal_to(const Vec3& axis) {
  const Vec3 other = std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return axis.cross(other).normalized();
}

void add_round_surface(const Vec3& centre, double radius, const Mat3& R, const Vec3& stretch,
                       std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris) {
  const int rings = 16, segments = 32;
  const int base = static_cast<int>(points.size());
  for (int i = 0; i <= rings; ++i) {
    const double theta = M_PI * i / rings;  // from the top
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * M_PI * j / segments;
      const Vec3 local(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      points.push_back(centre + radius * (R * local) + (i <= rings / 2 ? stretch : Vec3::Zero()));
    }
  }
  auto at = [&](int i, int j) { return base + i * segments + (j % segments); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      tris.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      tris.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
}

// The box's surface, wound outwards: two triangles per face when its edges are sharp; rounded,
// each face a grid whose lines near the face's rim sit where the rounding turns by equal angles
// (up to 45 degrees, the neighbouring face's grid taking the other half), every grid point
// then put on the rounded surface. Each edge's quarter circle gets 2 * kArcSteps chords, whose
// vertices lie on the surface, so the chords lie inside it.
void add_box_surface(const ColliderSpec& s, std::vector<Vec3>& points, std::vector<Eigen::Vector3i>& tris) {
  constexpr int kArcSteps = 4;
  const Mat3 R = rotation_from_degrees(s.rotation_deg);
  const double r = s.edge_radius;
  const Vec3 inner = s.half_extents - Vec3::Constant(r);
  std::array<std::vector<double>, 3> lines;
  for (int k = 0; k < 3; ++k) {
    std::vector<double>& l = lines[k];
    if (r > 0) {
      for (int j = kArcSteps; j >= 1; --j) l.push_back(-inner[k] - r * std::tan(M_PI / 4 * j / kArcSteps));
      l.push_back(-inner[k]);
      if (inner[k] > 0) l.push_back(inner[k]);
      for (int j = 1; j <= kArcSteps; ++j) l.push_back(inner[k] + r * std::tan(M_PI / 4 * j / kArcSteps));
    } else {
      l = {-s.half_extents[k], s.half_extents[k]};
    }
  }
  for (int axis = 0; axis < 3; ++axis)
    for (double side : {-1.0, 1.0}) {
      const int i = (axis + 1) % 3, j = (axis + 2) % 3;  // e_i x e_j = e_axis
      const int base = static_cast<int>(points.size());
      const int ni = static_cast<int>(lines[i].size()), nj = static_cast<int>(lines[j].size());
      for (int b = 0; b < nj; ++b)
        for (int a = 0; a < ni; ++a) {
          Vec3 p;
          p[axis] = side * s.half_extents[axis];
          p[i] = lines[i][a];
          p[j] = lines[j][b];
          if (r > 0) {
            const Vec3 c = p.cwiseMax(-inner).cwiseMin(inner);
            p = c + r * (p - c).normalized();
          }
          points.push_back(s.centre + R * p);
        }
      for (int b = 0; b + 1 < nj; ++b)
        for (int a = 0; a + 1 < ni; ++a) {
          const int v00 = base + b * ni + a, v10 = v00 + 1, v01 = v00 + ni, v11 = v01 + 1;
          if (side > 0) {
            tris.emplace_back(v00, v10, v11);
            tris.emplace_back(v00, v11, v01);
          } else {
            tris.emplace_back(v00, v11, v10);
            tris.emplace_back(v00, v01, v11);
          }
        }
    }
}

}  // namespace weft
