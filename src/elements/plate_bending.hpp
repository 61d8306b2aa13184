#pragma once
// Plate bending element: per triangle, the second derivatives of the deformation are fitted
// from the triangle's vertices and its neighbours in the flat pattern (a least-squares
// quadratic, exact for any quadratic field), and the energy is the orthotropic plate energy
//   E = 1/2 A (B_weft |x_uu|^2 + B_warp |x_vv|^2 + 2 B_twist |x_uv|^2),
// B_twist = sqrt(B_weft B_warp). Unlike the hinge element, it stores the right energy for
// cylindrical, spherical and twisted bends alike on any mesh; like it, it is linear in the
// positions (constant Jacobian) for a flat rest shape.
#include <vector>

#include "elements/bending.hpp"
#include "mesh/mesh.hpp"

namespace weft {

/// One stencil per triangle. Throws InputError naming a triangle whose neighbourhood is too
/// small to fit (fewer than 6 usable vertices).
std::vector<LinearBendingStencil> plate_bending_stencils(const TriMesh& mesh, double rigidity_weft_Nm,
                                                         double rigidity_warp_Nm);

}  // namespace weft
