#pragma once
// Central finite differences of one membrane triangle's energy and elastic force (no
// viscosity), for derivative tests.
#include <array>

#include "elements/membrane.hpp"

namespace weft::test {

struct MembraneDifferences {
  Eigen::Matrix<double, 9, 1> energy_gradient;
  Eigen::Matrix<double, 9, 9> force_jacobian;
};

inline MembraneDifferences membrane_finite_differences(const MembraneGeometry& g, const Material& mat,
                                                       const std::array<Vec3, 3>& x,
                                                       const std::array<Vec3, 3>& v, double h) {
  MembraneDifferences d;
  for (int k = 0; k < 9; ++k) {
    auto xp = x, xm = x;
    xp[k / 3][k % 3] += h;
    xm[k / 3][k % 3] -= h;
    MembraneResult rp, rm;
    evaluate_membrane(g, mat, Vec3::Zero(), xp, v, false, false, rp);
    evaluate_membrane(g, mat, Vec3::Zero(), xm, v, false, false, rm);
    d.energy_gradient[k] = (rp.energy - rm.energy) / (2 * h);
    d.force_jacobian.col(k) = (rp.force - rm.force) / (2 * h);
  }
  return d;
}

}  // namespace weft::test
