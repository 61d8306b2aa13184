#pragma once
// Validation of a panel outline before meshing (mesh/panel_mesher.hpp).
#include <string>

#include "mesh/panel_mesher.hpp"

namespace weft {

/// "outer point 3" or "hole 1 point 7": the name of point `index` of ring `ring` (ring 0 is
/// the outer boundary, ring k > 0 is hole k - 1).
std::string outline_point_name(int ring, int index);

/// Throws weft::InputError naming the points when a ring has fewer than 3 points, a point is
/// not finite or repeats another, a ring has zero area, two segments cross or touch, or a hole
/// is not inside the outer boundary or lies inside another hole.
void check_panel_outline(const PanelOutline& outline);

}  // namespace weft
