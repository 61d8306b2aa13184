#pragma once
// Basic numeric types shared by every part of weft. Positions are in metres, time in seconds.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace weft {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using VecX = Eigen::VectorXd;
using MatX = Eigen::MatrixXd;
/// #V by 3 array of points (row per vertex).
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #F by 3 array of vertex indices (row per triangle).
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// A 3n vector viewed as n 3D points.
inline Eigen::Map<Vec3> node(VecX& x, int i) { return Eigen::Map<Vec3>(x.data() + 3 * i); }
inline Eigen::Map<const Vec3> node(const VecX& x, int i) {
  return Eigen::Map<const Vec3>(x.data() + 3 * i);
}

/// The rows of a #F by 3 index matrix as vertex triples.
template <class Matrix>
std::vector<std::array<int, 3>> triangle_list(const Matrix& triangles) {
  std::vector<std::array<int, 3>> out(static_cast<size_t>(triangles.rows()));
  for (size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < 3; ++k) out[i][k] = triangles(static_cast<Eigen::Index>(i), k);
  return out;
}

}  // namespace weft
