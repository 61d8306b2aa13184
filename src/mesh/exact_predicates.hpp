#pragma once
// Orientation and in-circle tests whose signs are exact for any finite double inputs (no
// overflow or underflow assumed): a floating-point evaluation with an error bound decides the
// clear cases, and the rest are evaluated exactly with floating-point expansions (sums of
// non-overlapping doubles). The mesher's termination and consistency rest on these signs.
#include "weft/types.hpp"

namespace weft {

/// +1 if a, b, c turn counter-clockwise, -1 if clockwise, 0 if collinear.
int orientation_sign(const Vec2& a, const Vec2& b, const Vec2& c);

/// For a, b, c counter-clockwise: +1 if d lies inside their circumcircle, -1 outside, 0 on it.
int incircle_sign(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d);

}  // namespace weft
