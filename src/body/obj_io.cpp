// OBJ reading (vertices, faces, groups) and atomic OBJ writing for the body.
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "body/text.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

// Resolves a 1-based (or negative, relative) OBJ vertex reference "i[/t[/n]]".
int parse_vertex_ref(const std::string& token, int vertex_count, const std::string& where) {
  const std::string head = token.substr(0, token.find('/'));
  int index = 0;
  auto [ptr, ec] = std::from_chars(head.data(), head.data() + head.size(), index);
  if (ec != std::errc() || ptr != head.data() + head.size() || index == 0)
    throw InputError(where + ": bad vertex reference '" + token + "'");
  const int resolved = index > 0 ? index - 1 : vertex_count + index;
  if (resolved < 0 || resolved >= vertex_count)
    throw InputError(where + ": vertex reference " + head + " out of range (" +
                     std::to_string(vertex_count) + " vertices so far)");
  return resolved;
}

}  // namespace

ObjMesh read_obj(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open OBJ file");
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<std::set<int>> groups;
  ObjMesh mesh;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string where = path + ":" + std::to_string(line_number);
    std::istringstream tokens(line);
    std::string kind;
    if (!(tokens >> kind) || kind[0] == '#') continue;
    if (kind == "v") {
      Vec3 p;
      std::string value;
      for (int k = 0; k < 3; ++k) {
        if (!(tokens >> value)) throw InputError(where + ": vertex needs 3 coordinates");
        p[k] = text::parse_double(value, where);
      }
      vertices.push_back(p);
    } else if (kind == "f") {
      std::vector<int> face;
      std::string token;
      while (tokens >> token)
        face.push_back(parse_vertex_ref(token, static_cast<int>(vertices.size()), where));
      if (face.size() < 3) throw InputError(where + ": face needs at least 3 vertices");
      for (size_t k = 1; k + 1 < face.size(); ++k)
        triangles.emplace_back(face[0], face[k], face[k + 1]);
      if (!groups.empty()) groups.back().insert(face.begin(), face.end());
    } else if (kind == "g") {
      std::string name;
      tokens >> name;
      mesh.group_names.push_back(name);
      groups.emplace_back();
    }
  }
  mesh.positions.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  for (size_t i = 0; i < vertices.size(); ++i) mesh.positions.row(i) = vertices[i].transpose();
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t i = 0; i < triangles.size(); ++i) mesh.triangles.row(i) = triangles[i].transpose();
  for (const auto& g : groups) mesh.group_vertices.emplace_back(g.begin(), g.end());
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
