// weft's own OBJ reader. The packaged tinyobjloader (Debian's libtinyobjloader) is built with
// single-precision coordinates and reads leniently ("0.1x" as 0.1, "nan" accepted, face
// indices unchecked), so it cannot give the double-precision, line-numbered refusals that
// every weft reader owes its user (docs/reliability.md); the subset of OBJ weft needs (v, vt,
// vn, f, and statements it may ignore) is small enough to read strictly here.
#include "io/obj_file.hpp"

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>

#include "weft/input_file.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"

namespace weft {

namespace {

/// A token as it may be quoted in a message: clipped, with unprintable bytes as '?'.
std::string quoted(std::string_view token) {
  std::string s(token.substr(0, 40));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  return "'" + s + (token.size() > 40 ? "...'" : "'");
}

class ObjParser {
 public:
  ObjParser(std::string_view text, const std::string& name) : text_(text), name_(name) {}

  ObjData parse() {
    size_t start = 0;
    while (start <= text_.size()) {
      size_t end = text_.find('\n', start);
      if (end == std::string_view::npos) end = text_.size();
      ++line_;
      statement(text_.substr(start, end - start));
      start = end + 1;
    }
    close_group();
    // Indices may refer forwards (to vertices listed after the face): check them at the end.
    for (size_t t = 0; t < out_.triangles.size(); ++t)
      for (const auto& corner : out_.triangles[t]) {
        if (corner.vertex >= out_.vertex_count())
          fail_at(out_.triangle_line[t], "face refers to vertex " + std::to_string(corner.vertex + 1) +
                                             ", out of range (the file has " + std::to_string(out_.vertex_count()) +
                                             " vertices)");
        const int texcoords = static_cast<int>(out_.texcoords.size() / 2);
        if (corner.texcoord >= texcoords)
          fail_at(out_.triangle_line[t], "face refers to texture coordinate " + std::to_string(corner.texcoord + 1) +
                                             ", out of range (the file has " + std::to_string(texcoords) +
                                             " texture coordinates)");
      }
    for (size_t k = 0; k < normal_references_.size(); ++k)
      if (normal_references_[k].first > normals_)
        fail_at(normal_references_[k].second, "face refers to normal " + std::to_string(normal_references_[k].first) +
                                                  ", out of range (the file has " + std::to_string(normals_) +
                                                  " normals)");
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail_at(int line, const std::string& message) const {
    throw InputError(name_ + ":" + std::to_string(line) + ": " + message);
  }
  [[noreturn]] void fail(const std::string& message) const { fail_at(line_, message); }

  void statement(std::string_view line) {
    if (const size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    tokens_.clear();
    size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && is_space(line[i])) ++i;
      const size_t begin = i;
      while (i < line.size() && !is_space(line[i])) ++i;
      if (i > begin) tokens_.push_back(line.substr(begin, i - begin));
    }
    if (tokens_.empty()) return;
    const std::string_view keyword = tokens_[0];
    if (keyword == "v") {
      vertex();
    } else if (keyword == "vt") {
      texcoord();
    } else if (keyword == "vn") {
      expect_count(3, 3, "a normal (x y z)");
      for (int k = 1; k <= 3; ++k) coordinate(tokens_[k]);
      ++normals_;
    } else if (keyword == "f") {
      face();
    } else if (keyword == "g" || keyword == "o") {
      close_group();
      std::string group;
      for (size_t k = 1; k < tokens_.size(); ++k) group += (k > 1 ? " " : "") + std::string(tokens_[k]);
      open_group_ = true;
      group_ = ObjData::Group{group, out_.triangles.size(), out_.triangles.size()};
    } else if (keyword == "s" || keyword == "l" || keyword == "p" || keyword == "vp" || keyword == "usemtl" ||
               keyword == "mtllib") {
      // Smoothing groups, lines, points and materials do not concern a triangle mesh.
    } else {
      fail("unknown statement " + quoted(keyword) + " (expected v, vt, vn, f, g, o, s, l, p, vp, usemtl or mtllib)");
    }
  }

  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

  void expect_count(size_t lo, size_t hi, const std::string& what) const {
    const size_t n = tokens_.size() - 1;
    if (n < lo || n > hi)
      fail("expected " + what + ", got " + std::to_string(n) + " value" + (n == 1 ? "" : "s") +
           (n > hi ? " (trailing text " + quoted(tokens_[hi + 1]) + ")" : ""));
  }

  double number(std::string_view token) const {
    double value = 0;
    const char* begin = token.data();
    const char* end = begin + token.size();
    if (begin != end && *begin == '+') ++begin;
    const auto [ptr, ec] = std::from_chars(begin, end, value);
    if (ec == std::errc::result_out_of_range) fail("number " + quoted(token) + " is out of range");
    if (ec != std::errc() || ptr != end || begin == end) fail("expected a number, got " + quoted(token));
    if (!std::isfinite(value)) fail("expected a finite number, got " + quoted(token));
    return value;
  }

  double coordinate(std::string_view token) const {
    const double value = number(token);
    if (!(std::abs(value) <= kMaxObjCoordinate))
      fail("coordinate " + quoted(token) + " is out of range (expected a magnitude of at most 1e6)");
    return value;
  }

  void vertex() {
    const size_t n = tokens_.size() - 1;
    if (n != 3 && n != 4 && n != 6) expect_count(3, 3, "a vertex (x y z, x y z w or x y z r g b)");
    if (out_.vertex_count() == INT_MAX) fail("too many vertices");
    for (int k = 1; k <= 3; ++k) out_.positions.push_back(coordinate(tokens_[k]));
    for (size_t k = 4; k <= n; ++k) number(tokens_[k]);
    out_.position_line.push_back(line_);
  }

  void texcoord() {
    expect_count(1, 3, "a texture coordinate (u [v [w]])");
    const double u = coordinate(tokens_[1]);
    const double v = tokens_.size() > 2 ? coordinate(tokens_[2]) : 0.0;
    if (tokens_.size() > 3) coordinate(tokens_[3]);
    if (out_.texcoords.size() / 2 >= static_cast<size_t>(INT_MAX)) fail("too many texture coordinates");
    out_.texcoords.push_back(u);
    out_.texcoords.push_back(v);
  }

  /// A 1-based index (negative: relative to `count` read so far) as a 0-based one; forward
  /// references are checked once the whole file is read.
  int index(std::string_view token, long count, const char* what) const {
    long value = 0;
    const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || ptr != token.data() + token.size() || token.empty())
      fail("expected a " + std::string(what) + " index, got " + quoted(token));
    if (value == 0) fail(std::string(what) + " index 0 is out of range (indices start at 1)");
    const long resolved = value > 0 ? value - 1 : count + value;
    if (resolved < 0)
      fail(std::string(what) + " index " + std::to_string(value) + " is out of range (" + std::to_string(count) +
           " read so far)");
    if (resolved >= INT_MAX) fail(std::string(what) + " index " + std::to_string(value) + " is out of range");
    return static_cast<int>(resolved);
  }

  void face() {
    if (tokens_.size() < 4)
      fail("a face needs at least 3 corners, got " + std::to_string(tokens_.size() - 1));
    corners_.clear();
    for (size_t k = 1; k < tokens_.size(); ++k) {
      const std::string_view token = tokens_[k];
      const size_t slash1 = token.find('/');
      const size_t slash2 = slash1 == std::string_view::npos ? slash1 : token.find('/', slash1 + 1);
      if (slash2 != std::string_view::npos && token.find('/', slash2 + 1) != std::string_view::npos)
        fail("face corner " + quoted(token) + " has more than three parts (expected v, v/vt, v//vn or v/vt/vn)");
      ObjData::Corner c;
      c.vertex = index(token.substr(0, slash1), out_.vertex_count(), "vertex");
      if (slash1 != std::string_view::npos) {
        const std::string_view vt = token.substr(slash1 + 1, slash2 == std::string_view::npos ? slash2 : slash2 - slash1 - 1);
        if (!vt.empty()) {
          c.texcoord = index(vt, static_cast<long>(out_.texcoords.size() / 2), "texture coordinate");
        } else if (slash2 == std::string_view::npos) {
          fail("face corner " + quoted(token) + " has an empty texture coordinate index");
        }
        if (slash2 != std::string_view::npos)
          normal_references_.emplace_back(index(token.substr(slash2 + 1), normals_, "normal") + 1, line_);
      }
      corners_.push_back(c);
    }
    for (size_t k = 1; k + 1 < corners_.size(); ++k) {
      out_.triangles.push_back({corners_[0], corners_[k], corners_[k + 1]});
      out_.triangle_line.push_back(line_);
    }
  }

  void close_group() {
    if (!open_group_) return;
    group_.end_triangle = out_.triangles.size();
    if (group_.end_triangle > group_.first_triangle) out_.groups.push_back(group_);
    open_group_ = false;
  }

  std::string_view text_;
  const std::string& name_;
  int line_ = 0;
  std::vector<std::string_view> tokens_;
  std::vector<ObjData::Corner> corners_;
  long normals_ = 0;
  std::vector<std::pair<long, int>> normal_references_;  ///< (1-based normal, line)
  bool open_group_ = false;
  ObjData::Group group_;
  ObjData out_;
};

}  // namespace

ObjData parse_obj(std::string_view text, const std::string& name) { return ObjParser(text, name).parse(); }

ObjData read_obj_file(const std::string& path) { return parse_obj(read_input_file(path, "OBJ file"), path); }

TriMesh cloth_mesh_from_obj(const ObjData& obj, double uv_scale, const std::string& path) {
  const int nv = obj.vertex_count();
  if (nv < 3) throw InputError(path + ": OBJ mesh has " + std::to_string(nv) + " vertices, needs at least 3");
  TriMesh m;
  m.positions.resize(nv, 3);
  for (int i = 0; i < nv; ++i) {
    const Vec3 p(obj.positions[3 * i], obj.positions[3 * i + 1], obj.positions[3 * i + 2]);
    if (!(p.cwiseAbs().maxCoeff() <= kMaxLength_m))
      throw InputError(path + ":" + std::to_string(obj.position_line[i]) + ": vertex " + std::to_string(i + 1) +
                       " lies beyond " + nlohmann::json(kMaxLength_m).dump() +
                       " m (a cloth mesh is in metres; each coordinate must be within [-1e4, 1e4])");
    m.positions.row(i) = p.transpose();
  }
  std::vector<int> uv_of(nv, -1);
  std::vector<std::array<int, 3>> corner_uv;  // texture coordinate index per corner
  bool has_uv = !obj.texcoords.empty();
  bool several_places = false;  // a vertex with two different texture coordinates
  for (size_t f = 0; f < obj.triangles.size(); ++f) {
    const auto& corners = obj.triangles[f];
    const std::array<int, 3> t{corners[0].vertex, corners[1].vertex, corners[2].vertex};
    std::array<int, 3> uv{-1, -1, -1};
    for (int k = 0; k < 3 && has_uv; ++k) {
      const int ti = corners[k].texcoord;
      if (ti < 0) {
        has_uv = false;
        break;
      }
      uv[k] = ti;
      if (uv_of[t[k]] < 0)
        uv_of[t[k]] = ti;
      else if (uv_of[t[k]] != ti && (obj.texcoords[2 * uv_of[t[k]]] != obj.texcoords[2 * ti] ||
                                     obj.texcoords[2 * uv_of[t[k]] + 1] != obj.texcoords[2 * ti + 1]))
        several_places = true;
    }
    corner_uv.push_back(uv);
    m.triangles.push_back(t);
  }
  if (m.triangles.empty()) throw InputError(path + ": OBJ mesh has no faces");
  m.pattern.resize(nv);
  if (has_uv) {
    for (int i = 0; i < nv; ++i) {
      if (uv_of[i] < 0) throw InputError(path + ": vertex " + std::to_string(i + 1) + " is used by no face");
      m.pattern[i] = uv_scale * Vec2(obj.texcoords[2 * uv_of[i]], obj.texcoords[2 * uv_of[i] + 1]);
      if (!(m.pattern[i].cwiseAbs().maxCoeff() <= kMaxLength_m))
        throw InputError(path + ": vertex " + std::to_string(i + 1) + ": texture coordinates times uv_scale " +
                         nlohmann::json(uv_scale).dump() + " lie beyond " + nlohmann::json(kMaxLength_m).dump() +
                         " m (each pattern coordinate must be within [-1e4, 1e4] m)");
    }
  } else {
    // Project onto the best-fit plane: the pattern of a flat piece is its own shape.
    const Vec3 c = m.positions.colwise().mean().transpose();
    const MatX centred = m.positions.rowwise() - c.transpose();
    Eigen::JacobiSVD<MatX> svd(centred, Eigen::ComputeThinV);
    const Vec3 e1 = svd.matrixV().col(0), e2 = svd.matrixV().col(1);
    for (int i = 0; i < nv; ++i) {
      const Vec3 p = m.positions.row(i).transpose() - c;
      m.pattern[i] = Vec2(p.dot(e1), p.dot(e2));
    }
  }
  // A vertex on several pattern pieces (a sewn garment's seam): every corner keeps its own
  // texture coordinates.
  if (has_uv && several_places) {
    m.corner_pattern.resize(m.triangles.size());
    for (size_t f = 0; f < m.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k)
        m.corner_pattern[f][k] = uv_scale * Vec2(obj.texcoords[2 * corner_uv[f][k]], obj.texcoords[2 * corner_uv[f][k] + 1]);
  }
  // Orient every triangle counter-clockwise in the pattern.
  for (size_t f = 0; f < m.triangles.size(); ++f) {
    auto& t = m.triangles[f];
    const Vec2 e1 = m.corner(f, 1) - m.corner(f, 0), e2 = m.corner(f, 2) - m.corner(f, 0);
    if (e1.x() * e2.y() - e1.y() * e2.x() < 0) {
      std::swap(t[1], t[2]);
      if (!m.corner_pattern.empty()) std::swap(m.corner_pattern[f][1], m.corner_pattern[f][2]);
    }
  }
  return m;
}

TriMesh load_obj(const std::string& path, double uv_scale) {
  return cloth_mesh_from_obj(read_obj_file(path), uv_scale, path);
}

}  // namespace weft
