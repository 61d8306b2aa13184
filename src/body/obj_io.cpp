// OBJ reading (vertices, faces, groups; tinyobjloader) and atomic OBJ writing for the body.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "io/obj_file.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

ObjMesh read_obj(const std::string& path) {
  const tinyobj::ObjReader reader = parse_obj_file(path, "file");
  const auto& coordinates = reader.GetAttrib().vertices;
  const Eigen::Index nv = static_cast<Eigen::Index>(coordinates.size() / 3);
  ObjMesh mesh;
  mesh.positions.resize(nv, 3);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      mesh.positions(i, k) = coordinates[3 * i + k];
      if (!std::isfinite(mesh.positions(i, k)))
        throw InputError(path + ": vertex " + std::to_string(i + 1) + " has a non-finite coordinate");
    }
  std::vector<Eigen::Vector3i> triangles;
  for (const auto& shape : reader.GetShapes()) {
    // Faces before the first `g` line (an unnamed shape) belong to no group.
    const bool grouped = !shape.name.empty();
    std::set<int> vertices;
    const auto& idx = shape.mesh.indices;
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
      Eigen::Vector3i t;
      for (int k = 0; k < 3; ++k) {
        t[k] = idx[f + k].vertex_index;
        if (t[k] < 0 || t[k] >= nv)
          throw InputError(path + ": face " + std::to_string(triangles.size() + 1) + " refers to vertex " +
                           std::to_string(t[k] + 1) + ", out of range (" + std::to_string(nv) + " vertices)");
        if (grouped) vertices.insert(t[k]);
      }
      triangles.push_back(t);
    }
    if (grouped) {
      mesh.group_names.push_back(shape.name);
      mesh.group_vertices.emplace_back(vertices.begin(), vertices.end());
    }
  }
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t i = 0; i < triangles.size(); ++i) mesh.triangles.row(static_cast<Eigen::Index>(i)) = triangles[i].transpose();
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
