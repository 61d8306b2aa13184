#include "elements/bending.hpp"

#include <cmath>

namespace weft {

namespace {
double cross2(const Vec2& p, const Vec2& q) { return p.x() * q.y() - p.y() * q.x(); }
}  // namespace

bool make_bending_geometry(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d,
                           double rigidity_weft_Nm, double rigidity_warp_Nm, BendingGeometry& g) {
  const Vec2 cd = d - c;
  const double len = cd.norm();
  if (!(len > 0)) return false;
  // Tip heights over the hinge line.
  const double ha = std::abs(cross2(cd, a - c)) / len;
  const double hb = std::abs(cross2(cd, b - c)) / len;
  if (!(ha > 1e-9 * len) || !(hb > 1e-9 * len)) return false;
  // Solve s A + (1 - s) B = t C + (1 - t) D for (s, t).
  Mat2 m;
  m.col(0) = a - b;
  m.col(1) = d - c;
  const double det = m.determinant();
  if (std::abs(det) < 1e-12 * (a - b).norm() * len) return false;
  const Vec2 st = m.inverse() * (d - b);
  const double s = st[0], t = st[1];
  g.alpha = Eigen::Vector4d(s, 1 - s, -t, -(1 - t));
  if (!g.alpha.allFinite() || g.alpha.cwiseAbs().maxCoeff() > 1e3) return false;
  const Vec2 n = Vec2(-cd.y(), cd.x()) / len;
  const double rigidity = rigidity_weft_Nm * n.x() * n.x() + rigidity_warp_Nm * n.y() * n.y();
  // k_b = 2 (h_A + h_B) / (h_A^2 h_B^2) |CD| B (docs/method.md 5). The formula the hinge was
  // first written from has 2/3 for the constant, which assumes every hinge sees the whole
  // curvature; a hinge measures the difference of the curvatures along its quad's two
  // diagonals, and a sheet rolled into a cylinder (the bend that B is measured in) then stores
  // a third of B k^2 / 2 per area, on square grids and on equilateral meshes alike. With 2 it
  // stores B k^2 / 2 (tests/elements/test_elements.cpp).
  g.stiffness = 2.0 * (ha + hb) / (ha * ha * hb * hb) * len * rigidity;
  g.kappa_factor = g.alpha.squaredNorm();
  return true;
}

}  // namespace weft

namespace weft {

double LinearBendingStencil::stiffness_mass_sum(const VecX& inverse_mass) const {
  double s = 0;
  for (Eigen::Index m = 0; m < measures.rows(); ++m)
    for (Eigen::Index k = 0; k < measures.cols(); ++k)
      s += weights[m] * measures(m, k) * measures(m, k) * inverse_mass[vertices[k]];
  return s;
}

LinearBendingStencil hinge_stencil(const std::array<int, 4>& vertices, const BendingGeometry& g) {
  LinearBendingStencil s;
  s.vertices.assign(vertices.begin(), vertices.end());
  s.measures = g.alpha.transpose();
  s.weights = VecX::Constant(1, g.stiffness);
  s.finish();
  return s;
}

}  // namespace weft
