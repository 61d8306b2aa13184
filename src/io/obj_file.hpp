#pragma once
// Reading OBJ files: a strict reader shared by the cloth mesh and the body. Coordinates are read
// in double precision; every error names the file and the line.
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "mesh/mesh.hpp"

namespace weft {

/// Largest magnitude of an OBJ coordinate or texture coordinate, in the file's units.
constexpr double kMaxObjCoordinate = 1e6;

/// What an OBJ file holds, polygons split into triangles as fans.
struct ObjData {
  struct Corner {
    int vertex = 0;     ///< 0-based
    int texcoord = -1;  ///< 0-based, -1 when the face gives none
  };
  struct Group {
    std::string name;
    size_t first_triangle = 0, end_triangle = 0;  ///< the triangles of its faces
  };
  std::vector<double> positions;  ///< 3 per vertex
  std::vector<int> position_line; ///< line of each vertex
  std::vector<double> texcoords;  ///< 2 (u, v) per texture coordinate
  std::vector<std::array<Corner, 3>> triangles;
  std::vector<int> triangle_line;  ///< line of the face each triangle comes from
  std::vector<Group> groups;       ///< `g` and `o` groups that have faces, in file order
  int vertex_count() const { return static_cast<int>(positions.size() / 3); }
};

/// Parses OBJ text: `v x y z [w]` (or `v x y z r g b`), `vt u [v [w]]`, `vn x y z`,
/// `f a b c ...` with corners `v`, `v/vt`, `v//vn` or `v/vt/vn` (negative indices count back
/// from the last one read), `g`/`o` NAME; `s`, `l`, `p`, `usemtl`, `mtllib` and comments are
/// ignored. Throws InputError "NAME:LINE: ..." for an unknown statement, a number that does not
/// parse or is not finite or beyond kMaxObjCoordinate, trailing text, and an index out of range.
ObjData parse_obj(std::string_view text, const std::string& name);
/// Reads and parses the OBJ file at `path`.
ObjData read_obj_file(const std::string& path);

/// The cloth mesh of parsed OBJ data (`name` for messages): pattern coordinates from the
/// texture coordinates times `uv_scale` (metres per texture unit) when every face corner has
/// them, otherwise from the positions projected onto their best-fit plane. Coordinates are in
/// metres and must lie within kMaxLength_m (scene.hpp). A vertex whose corners carry different
/// texture coordinates lies on several pattern pieces (a sewn garment's seam): the mesh then
/// keeps them per corner (TriMesh::corner_pattern). Throws InputError naming the file.
TriMesh cloth_mesh_from_obj(const ObjData& obj, double uv_scale, const std::string& name);
/// read_obj_file then cloth_mesh_from_obj.
TriMesh load_obj(const std::string& path, double uv_scale = 1.0);

}  // namespace weft
