#include "elements/spring.hpp"

#include <algorithm>

namespace weft {

void evaluate_spring(double k, double rest_length, double l, const Vec3& x1, const Vec3& x2,
                     const Vec3& v1, const Vec3& v2, bool definite, SpringResult& out) {
  const Vec3 d = x1 - x2, dv = v1 - v2;
  if (rest_length == 0.0) {
    // Zero rest length: exactly linear, f = -k d - l d'.
    out.energy = 0.5 * k * d.squaredNorm();
    out.force = -k * d - l * dv;
    out.stiffness = -k * Mat3::Identity();
    out.damping = -l * Mat3::Identity();
    out.viscous_power = -l * dv.squaredNorm();
    return;
  }
  const double len = d.norm();
  const Vec3 n = d / len;
  const double stretch = len - rest_length;
  const double rate = n.dot(dv);
  out.energy = 0.5 * k * stretch * stretch;
  out.force = -(k * stretch + l * rate) * n;
  const Mat3 nn = n * n.transpose();
  double lateral = 1.0 - rest_length / len;  // negative when compressed
  if (definite) lateral = std::max(lateral, 0.0);
  out.stiffness = -k * (nn + lateral * (Mat3::Identity() - nn));
  out.damping = -l * nn;
  out.viscous_power = -l * rate * rate;
}

}  // namespace weft
