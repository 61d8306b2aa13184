#include "mesh/exact_predicates.hpp"

#include <cmath>
#include <vector>

namespace weft {
namespace {

// An expansion: doubles of increasing magnitude, non-overlapping, whose exact sum is the value.
using Expansion = std::vector<double>;

void two_sum(double a, double b, double& sum, double& error) {
  sum = a + b;
  const double b_virtual = sum - a;
  const double a_virtual = sum - b_virtual;
  error = (a - a_virtual) + (b - b_virtual);
}

// e += b, exactly (zero components dropped; the result stays non-overlapping and ordered).
// In place: the k-th component kept comes from the k-th component read or a later one, so it
// is written where nothing still to be read lies (no allocation but for the expansion's growth).
void grow(Expansion& e, double b) {
  double q = b;
  size_t kept = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    double sum, error;
    two_sum(q, e[i], sum, error);
    if (error != 0.0) e[kept++] = error;
    q = sum;
  }
  e.resize(kept);
  if (q != 0.0) e.push_back(q);
}

Expansion difference(double a, double b) {
  Expansion e;
  grow(e, a);
  grow(e, -b);
  return e;
}

Expansion product(const Expansion& a, const Expansion& b) {
  Expansion out;
  for (double x : a)
    for (double y : b) {
      const double p = x * y;
      grow(out, std::fma(x, y, -p));  // the exact rounding error of x * y
      grow(out, p);
    }
  return out;
}

Expansion plus(Expansion a, const Expansion& b) {
  for (double x : b) grow(a, x);
  return a;
}

Expansion minus(Expansion a, const Expansion& b) {
  for (double x : b) grow(a, -x);
  return a;
}

int sign_of(const Expansion& e) {
  // The last component is the largest in magnitude and carries the sign.
  if (e.empty()) return 0;
  return e.back() > 0 ? 1 : -1;
}

// Relative error bounds of the plain double evaluations below, with a margin over the bounds
// proved by Shewchuk (3 eps and 10 eps, eps = 2^-53) since the evaluation order differs a little.
constexpr double kOrientBound = 1e-15;
constexpr double kIncircleBound = 4e-15;
// orient3d: Shewchuk's bound is 7 eps over the permanent of the rounded differences; the
// differences' own rounding is inside it. Ten times that.
constexpr double kOrient3dBound = 1e-14;

}  // namespace

int orientation_sign(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double left = (a.x() - c.x()) * (b.y() - c.y());
  const double right = (a.y() - c.y()) * (b.x() - c.x());
  const double det = left - right;
  const double bound = kOrientBound * (std::abs(left) + std::abs(right));
  if (det > bound) return 1;
  if (det < -bound) return -1;
  const Expansion exact = minus(product(difference(a.x(), c.x()), difference(b.y(), c.y())),
                                product(difference(a.y(), c.y()), difference(b.x(), c.x())));
  return sign_of(exact);
}

int orient3d_sign(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // det [u; v; w] with u = b - a, v = c - a, w = d - a, expanded along u.
  const double ux = b.x() - a.x(), uy = b.y() - a.y(), uz = b.z() - a.z();
  const double vx = c.x() - a.x(), vy = c.y() - a.y(), vz = c.z() - a.z();
  const double wx = d.x() - a.x(), wy = d.y() - a.y(), wz = d.z() - a.z();
  const double det = ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx);
  const double permanent = std::abs(ux) * (std::abs(vy * wz) + std::abs(vz * wy)) +
                           std::abs(uy) * (std::abs(vz * wx) + std::abs(vx * wz)) +
                           std::abs(uz) * (std::abs(vx * wy) + std::abs(vy * wx));
  const double bound = kOrient3dBound * permanent;
  if (det > bound) return 1;
  if (det < -bound) return -1;
  const Expansion eux = difference(b.x(), a.x()), euy = difference(b.y(), a.y()), euz = difference(b.z(), a.z());
  const Expansion evx = difference(c.x(), a.x()), evy = difference(c.y(), a.y()), evz = difference(c.z(), a.z());
  const Expansion ewx = difference(d.x(), a.x()), ewy = difference(d.y(), a.y()), ewz = difference(d.z(), a.z());
  const Expansion exact = plus(plus(product(eux, minus(product(evy, ewz), product(evz, ewy))),
                                    product(euy, minus(product(evz, ewx), product(evx, ewz)))),
                               product(euz, minus(product(evx, ewy), product(evy, ewx))));
  return sign_of(exact);
}

int incircle_sign(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double adx = a.x() - d.x(), ady = a.y() - d.y();
  const double bdx = b.x() - d.x(), bdy = b.y() - d.y();
  const double cdx = c.x() - d.x(), cdy = c.y() - d.y();
  const double alift = adx * adx + ady * ady;
  const double blift = bdx * bdx + bdy * bdy;
  const double clift = cdx * cdx + cdy * cdy;
  const double bc = bdx * cdy - cdx * bdy, ca = cdx * ady - adx * cdy, ab = adx * bdy - bdx * ady;
  const double det = alift * bc + blift * ca + clift * ab;
  const double permanent = (std::abs(bdx * cdy) + std::abs(cdx * bdy)) * alift +
                           (std::abs(cdx * ady) + std::abs(adx * cdy)) * blift +
                           (std::abs(adx * bdy) + std::abs(bdx * ady)) * clift;
  const double bound = kIncircleBound * permanent;
  if (det > bound) return 1;
  if (det < -bound) return -1;

  const Expansion eadx = difference(a.x(), d.x()), eady = difference(a.y(), d.y());
  const Expansion ebdx = difference(b.x(), d.x()), ebdy = difference(b.y(), d.y());
  const Expansion ecdx = difference(c.x(), d.x()), ecdy = difference(c.y(), d.y());
  const Expansion ealift = plus(product(eadx, eadx), product(eady, eady));
  const Expansion eblift = plus(product(ebdx, ebdx), product(ebdy, ebdy));
  const Expansion eclift = plus(product(ecdx, ecdx), product(ecdy, ecdy));
  const Expansion ebc = minus(product(ebdx, ecdy), product(ecdx, ebdy));
  const Expansion eca = minus(product(ecdx, eady), product(eadx, ecdy));
  const Expansion eab = minus(product(eadx, ebdy), product(ebdx, eady));
  const Expansion exact =
      plus(plus(product(ealift, ebc), product(eblift, eca)), product(eclift, eab));
  return sign_of(exact);
}

}  // namespace weft
