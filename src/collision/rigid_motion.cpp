// Rigid motions of colliders: rotations from degrees and back, a motion's pose at a time.
#include "weft/collider.hpp"

#include <algorithm>
#include <cmath>

namespace weft {

Mat3 rotation_from_degrees(const Vec3& deg) {
  const Vec3 r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

Vec3 degrees_from_rotation(const Mat3& R) {
  // R = Rz(c) Ry(b) Rx(a): Eigen's angles about the axes 2, 1, 0 in that order.
  const Vec3 zyx = R.eulerAngles(2, 1, 0);
  return Vec3(zyx.z(), zyx.y(), zyx.x()) * (180.0 / M_PI);
}

Eigen::Isometry3d RigidMotion::at(double t) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  switch (kind) {
    case Kind::kStatic:
      break;
    case Kind::kVelocity: {
      // Turning about the moving centre c + v t: x -> R (x - c) + c + v t.
      const double angle = angular_velocity.norm() * t;
      const Mat3 R = angle > 0 ? Eigen::AngleAxisd(angle, angular_velocity.normalized()).toRotationMatrix()
                               : Mat3::Identity();
      T.linear() = R;
      T.translation() = centre + linear_velocity * t - R * centre;
      break;
    }
    case Kind::kKeyframes: {
      if (keys.empty()) break;
      size_t k = 0;
      while (k + 1 < keys.size() && keys[k + 1].time <= t) ++k;
      const Key& a = keys[k];
      const Key& b = k + 1 < keys.size() ? keys[k + 1] : keys[k];
      const double s = b.time > a.time ? std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0) : 0.0;
      const Eigen::Quaterniond qa(rotation_from_degrees(a.rotation_deg)), qb(rotation_from_degrees(b.rotation_deg));
      T.linear() = qa.slerp(s, qb).toRotationMatrix();
      T.translation() = (1 - s) * a.translation + s * b.translation;
      break;
    }
  }
  return T;
}

}  // namespace weft
