#pragma once
// Triangle meshes of cloth: 3D positions plus 2D pattern (material) coordinates per vertex,
// u along the weft and v along the warp, in metres.
#include <array>
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

}  // namespace weft
