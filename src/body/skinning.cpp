// Linear blend and dual-quaternion skinning of a mesh by per-bone rigid transforms.
#include <algorithm>

#include "weft/body.hpp"
#include "util/threads.hpp"

namespace weft {

namespace {

// Runs body(v) for every vertex, in pieces of 1,024 on the threads allowed: each vertex writes
// only its own row, so the result is the same at every thread count.
template <class Body>
void for_each_vertex(Eigen::Index count, const Body& body) {
  constexpr Eigen::Index kPiece = 1024;
  parallel_chunks(static_cast<size_t>((count + kPiece - 1) / kPiece), [&](size_t k) {
    const Eigen::Index begin = static_cast<Eigen::Index>(k) * kPiece;
    for (Eigen::Index v = begin, end = std::min(count, begin + kPiece); v < end; ++v) body(v);
  });
}

void check_sizes(const Points& rest, const SkinWeights& weights) {
  if (weights.bone.rows() != rest.rows() || weights.weight.rows() != rest.rows())
    throw std::invalid_argument("skinning: weights and rest positions differ in size");
}

}  // namespace

void skin_lbs(const Points& rest, const SkinWeights& weights, const std::vector<BonePose>& poses,
              Points& out) {
  check_sizes(rest, weights);
  // Each bone as a 3x4 matrix [R | t]; a vertex blends the matrices, then applies the blend.
  std::vector<Eigen::Matrix<double, 3, 4>> m(poses.size());
  for (size_t b = 0; b < poses.size(); ++b) {
    m[b].leftCols<3>() = poses[b].rotation.toRotationMatrix();
    m[b].col(3) = poses[b].translation;
  }
  out.resize(rest.rows(), 3);
  for_each_vertex(rest.rows(), [&](Eigen::Index v) {
    Eigen::Matrix<double, 3, 4> blend = weights.weight(v, 0) * m[weights.bone(v, 0)];
    for (int k = 1; k < SkinWeights::kInfluences; ++k)
      blend += weights.weight(v, k) * m[weights.bone(v, k)];
    out.row(v) = (blend.leftCols<3>() * rest.row(v).transpose() + blend.col(3)).transpose();
  });
}

void skin_dqs(const Points& rest, const SkinWeights& weights, const std::vector<BonePose>& poses,
              Points& out) {
  check_sizes(rest, weights);
  // Unit dual quaternion q0 + eps qe with qe = 0.5 (0, t) q0, stored as 8 coefficients.
  using Vec8 = Eigen::Matrix<double, 8, 1>;
  std::vector<Vec8> dq(poses.size());
  for (size_t b = 0; b < poses.size(); ++b) {
    const Eigen::Quaterniond& q0 = poses[b].rotation;
    const Vec3& t = poses[b].translation;
    const Eigen::Quaterniond qe =
        Eigen::Quaterniond(0, 0.5 * t.x(), 0.5 * t.y(), 0.5 * t.z()) * q0;
    dq[b] << q0.w(), q0.x(), q0.y(), q0.z(), qe.w(), qe.x(), qe.y(), qe.z();
  }
  out.resize(rest.rows(), 3);
  for_each_vertex(rest.rows(), [&](Eigen::Index v) {
    const Vec8& first = dq[weights.bone(v, 0)];
    Vec8 blend = weights.weight(v, 0) * first;
    for (int k = 1; k < SkinWeights::kInfluences; ++k) {
      const Vec8& d = dq[weights.bone(v, k)];
      // Blend in the hemisphere of the first influence (q and -q are the same rotation).
      const double sign = first.head<4>().dot(d.head<4>()) < 0 ? -1.0 : 1.0;
      blend += (sign * weights.weight(v, k)) * d;
    }
    const double inverse_norm = 1.0 / blend.head<4>().norm();
    const double w = blend[0] * inverse_norm, ew = blend[4] * inverse_norm;
    const Vec3 qv = blend.segment<3>(1) * inverse_norm;
    const Vec3 ev = blend.segment<3>(5) * inverse_norm;
    // Translation: the vector part of 2 qe conj(q0); rotation: x + 2 w (v x x) + 2 v x (v x x).
    const Vec3 t = 2.0 * (w * ev - ew * qv + qv.cross(ev));
    const Vec3 x = rest.row(v).transpose();
    const Vec3 vx = qv.cross(x);
    out.row(v) = (x + 2.0 * (w * vx + qv.cross(vx)) + t).transpose();
  });
}

}  // namespace weft
