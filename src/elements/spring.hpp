#pragma once
// A linear spring with viscosity between two points (the one-spring model of docs/method.md 3
// and a building block for tests). One end may be a fixed anchor.
#include "weft/types.hpp"

namespace weft {

struct SpringResult {
  double energy = 0;
  Vec3 force;            ///< on end 1; end 2 receives -force
  Mat3 stiffness;        ///< d force_1 / d x_1 (= d force_2 / d x_2; off-diagonal = -this)
  Mat3 damping;          ///< d force_1 / d v_1
  double viscous_power = 0;
};

/// Spring of stiffness k (N/m), rest length L0 (m) and viscosity l (N s/m) along its axis
/// (or isotropic when L0 = 0, where the axis is undefined). `definite` drops the negative
/// part of the Hessian under compression.
void evaluate_spring(double k, double rest_length, double l, const Vec3& x1, const Vec3& x2,
                     const Vec3& v1, const Vec3& v2, bool definite, SpringResult& out);

}  // namespace weft
