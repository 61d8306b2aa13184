#pragma once
// Triangle meshes of cloth: 3D positions plus 2D pattern (material) coordinates per vertex,
// u along the weft and v along the warp, in metres.
#include <array>
#include <string>
#include <vector>

#include "weft/mesh.hpp"
#include "weft/types.hpp"

namespace weft {


/// Bending stencils: for every interior edge CD shared by triangles (C, D, A) and (D, C, B),
/// the vertex indices (A, B, C, D).
std::vector<std::array<int, 4>> interior_edge_stencils(const TriMesh& mesh);

/// A bending stencil with the pattern coordinates of its four vertices laid out flat: the
/// pattern of triangle (C, D, A) as it is, and triangle (D, C, B) turned and moved so that its
/// edge CD lies on the first one's (where the two triangles come from different pattern
/// pieces, their common edge is unfolded; its two lengths are averaged about its midpoint).
struct FlatStencil {
  std::array<int, 4> vertices;  ///< A, B, C, D
  std::array<Vec2, 4> pattern;  ///< their flat pattern coordinates
  std::array<int, 2> triangles; ///< the triangles holding A and B (indices into TriMesh::triangles)
};
std::vector<FlatStencil> interior_edge_flat_stencils(const TriMesh& mesh);

/// The vertices in bands across the pattern: each connected piece in turn (by its lowest
/// vertex index), within a piece by v in units of the row spacing (the median rise of the
/// edges that cross rows), rounded, then by u.
/// On a grid this is its own numbering (rows along u); on a mesh whose vertex numbering is
/// scrambled it restores rows, which the Gauss-Seidel-type solvers need (the SSOR
/// preconditioner takes the nodes in this order).
std::vector<int> banded_order(const TriMesh& mesh);

}  // namespace weft
