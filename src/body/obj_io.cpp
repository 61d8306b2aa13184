// OBJ reading (vertices, faces, groups) and atomic OBJ writing for the body.
#include <cstdio>
#include <filesystem>
#include <set>

#include "io/obj_file.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

ObjMesh read_obj(const std::string& path) {
  const ObjData obj = read_obj_file(path);
  const Eigen::Index nv = obj.vertex_count();
  ObjMesh mesh;
  mesh.positions.resize(nv, 3);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) mesh.positions(i, k) = obj.positions[3 * i + k];
  mesh.triangles.resize(static_cast<Eigen::Index>(obj.triangles.size()), 3);
  for (size_t t = 0; t < obj.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) mesh.triangles(static_cast<Eigen::Index>(t), k) = obj.triangles[t][k].vertex;
  // Faces before the first `g` line belong to no group.
  for (const auto& group : obj.groups) {
    if (group.name.empty()) continue;
    std::set<int> vertices;
    for (size_t t = group.first_triangle; t < group.end_triangle; ++t)
      for (const auto& corner : obj.triangles[t]) vertices.insert(corner.vertex);
    mesh.group_names.push_back(group.name);
    mesh.group_vertices.emplace_back(vertices.begin(), vertices.end());
  }
  return mesh;
}

void write_obj(const std::string& path, const Points& positions, const Triangles& triangles) {
  const std::string temporary = path + ".tmp";
  {
    std::FILE* f = std::fopen(temporary.c_str(), "w");
    if (!f) throw InputError(path + ": cannot write");
    std::string buffer;
    buffer.reserve(static_cast<size_t>(positions.rows() + triangles.rows()) * 40);
    char text[96];
    for (Eigen::Index i = 0; i < positions.rows(); ++i) {
      const int n = std::snprintf(text, sizeof text, "v %.6f %.6f %.6f\n", positions(i, 0),
                                  positions(i, 1), positions(i, 2));
      buffer.append(text, static_cast<size_t>(n));
    }
    for (Eigen::Index i = 0; i < triangles.rows(); ++i) {
      const int n = std::snprintf(text, sizeof text, "f %d %d %d\n", triangles(i, 0) + 1,
                                  triangles(i, 1) + 1, triangles(i, 2) + 1);
      buffer.append(text, static_cast<size_t>(n));
    }
    const bool ok = std::fwrite(buffer.data(), 1, buffer.size(), f) == buffer.size();
    if (std::fclose(f) != 0 || !ok) throw InputError(path + ": write failed");
  }
  std::filesystem::rename(temporary, path);
}

}  // namespace weft
