#pragma once
// Orientation and in-circle tests whose signs are exact for any finite double inputs (no
// overflow or underflow assumed): a floating-point evaluation with an error bound decides the
// clear cases, and the rest are evaluated exactly with floating-point expansions (sums of
// non-overlapping doubles). The mesher's termination and consistency rest on these signs.
#include "weft/types.hpp"

namespace weft {

/// +1 if a, b, c turn counter-clockwise, -1 if clockwise, 0 if collinear.
int orientation_sign(const Vec2& a, const Vec2& b, const Vec2& c);

/// The sign of (b - a) x (c - a) . (d - a): +1 when d lies on the side of the plane abc that
/// the normal of the counter-clockwise triangle (a, b, c) points to, -1 on the other, 0 when
/// the four points are coplanar.
int orient3d_sign(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// For a, b, c counter-clockwise: +1 if d lies inside their circumcircle, -1 outside, 0 on it.
int incircle_sign(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d);

}  // namespace weft
