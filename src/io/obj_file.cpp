#include "io/obj_file.hpp"

#include "weft/error.hpp"

namespace weft {

tinyobj::ObjReader parse_obj_file(const std::string& path, const std::string& what) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    std::string msg = reader.Error();
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == '\r')) msg.pop_back();
    throw InputError(path + ": cannot read OBJ " + what + (msg.empty() ? "" : ": " + msg));
  }
  return reader;
}

}  // namespace weft
