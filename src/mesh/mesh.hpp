#pragma once
// Triangle meshes of cloth: 3D positions plus 2D pattern (material) coordinates per vertex,
// u along the weft and v along the warp, in metres.
#include <array>
#include <string>
#include <vector>

#include "weft/types.hpp"

namespace weft {

struct TriMesh {
  Points positions;                           ///< #V by 3 (m)
  std::vector<Vec2> pattern;                  ///< #V pattern coordinates (m)
  std::vector<std::array<int, 3>> triangles;  ///< #F vertex indices, counter-clockwise in the pattern
  /// Pattern coordinates per triangle corner, for meshes whose vertices lie on several
  /// pattern pieces (a sewn garment: a seam vertex has a place on each panel it joins).
  /// Empty when every corner takes its vertex's `pattern`; otherwise #F entries, and
  /// `pattern` holds one of each vertex's places (for orderings and per-vertex outputs).
  std::vector<std::array<Vec2, 3>> corner_pattern;
  int num_vertices() const { return static_cast<int>(positions.rows()); }
  /// The pattern coordinates of corner k of triangle t.
  const Vec2& corner(size_t t, int k) const {
    return corner_pattern.empty() ? pattern[triangles[t][k]] : corner_pattern[t][k];
  }
};

/// A zero-length spring that pulls two vertices of a mesh together (a seam being sewn):
/// energy stiffness_N_m / 2 |x_a - x_b|^2.
struct Seam {
  int a = 0, b = 0;
  double stiffness_N_m = 0;
};

/// How make_grid splits its cells into triangles.
enum class GridPattern {
  kAlternatingDiagonals,  ///< squares split along alternating diagonals (no preferred shear)
  kShiftedRows,           ///< odd rows shifted by half a cell along u: with rows sqrt(3)/2 of a
                          ///< cell apart the triangles are equilateral
};

/// A size_u by size_v rectangle in the z = 0 plane with nu by nv vertices; vertex (i, j)
/// (i along u, j along v) has index j * nu + i (with kShiftedRows, odd rows reach half a cell
/// beyond size_u).
TriMesh make_grid(double size_u, double size_v, int nu, int nv,
                  GridPattern pattern = GridPattern::kAlternatingDiagonals);

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

/// Writes positions and triangles as an OBJ file (atomically).
void write_obj(const std::string& path, const VecX& x, const std::vector<std::array<int, 3>>& triangles);

}  // namespace weft
