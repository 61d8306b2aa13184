#pragma once
// Reading OBJ files with tinyobjloader, shared by the cloth mesh and the body readers.
#include <tiny_obj_loader.h>

#include <string>

namespace weft {

/// Parses the OBJ file at `path` with polygons split into triangles. Throws InputError
/// "PATH: cannot read OBJ WHAT: REASON" (REASON as tinyobjloader gives it) when it cannot.
tinyobj::ObjReader parse_obj_file(const std::string& path, const std::string& what);

}  // namespace weft
