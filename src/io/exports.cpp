// weft's own glb and PC2 writers. Debian packages tinygltf, but its writer builds the whole
// model (every buffer copied into its structures) before serialising; the glb layout is a
// JSON chunk and a binary chunk, which weft writes here straight from the recorded frames
// with the JSON library it already uses.
#include "weft/exports.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "weft/error.hpp"

namespace weft {

static_assert(std::endian::native == std::endian::little, "glb and PC2 are little-endian; weft writes memory as is");

std::vector<std::string> split_format_list(const std::string& text) {
  std::vector<std::string> names;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t first = item.find_first_not_of(' '), last = item.find_last_not_of(' ');
    names.push_back(first == std::string::npos ? std::string() : item.substr(first, last - first + 1));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return names;
}

std::vector<std::string> checked_output_formats(const std::vector<std::string>& names, const std::string& where) {
  static const std::vector<std::string> known = {"obj", "ply", "glb", "pc2", "usda"};
  if (names.empty()) throw InputError(where + ": no output format given (expected one or more of " + kOutputFormatNames + ")");
  std::vector<std::string> out;
  for (const auto& n : names) {
    if (std::find(known.begin(), known.end(), n) == known.end())
      throw InputError(where + ": unknown output format '" + n + "' (expected " + kOutputFormatNames + ")");
    if (std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
  }
  if (std::find(out.begin(), out.end(), "obj") != out.end() && std::find(out.begin(), out.end(), "ply") != out.end())
    throw InputError(where + ": obj and ply cannot both be chosen: both write the frames DIR/frames/frame_NNNNN "
                             "(choose one; ply adds the per-vertex added viscosity)");
  return out;
}

template <typename Real>
std::vector<float> vertex_normals(const Real* xyz, int vertex_count, const std::vector<std::array<int, 3>>& triangles) {
  std::vector<double> sum(3 * static_cast<size_t>(vertex_count), 0.0);
  for (const auto& t : triangles) {
    const Real *a = xyz + 3 * t[0], *b = xyz + 3 * t[1], *c = xyz + 3 * t[2];
    const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    // The cross product's length is twice the area: summing it weights each face by area.
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) sum[3 * static_cast<size_t>(t[k]) + d] += n[d];
  }
  std::vector<float> out(sum.size());
  for (size_t i = 0; i < sum.size(); i += 3) {
    const double len = std::sqrt(sum[i] * sum[i] + sum[i + 1] * sum[i + 1] + sum[i + 2] * sum[i + 2]);
    if (len > 0 && std::isfinite(len)) {
      for (int d = 0; d < 3; ++d) out[i + d] = static_cast<float>(sum[i + d] / len);
    } else {
      out[i] = 0, out[i + 1] = 0, out[i + 2] = 1;
    }
  }
  return out;
}

template std::vector<float> vertex_normals<double>(const double*, int, const std::vector<std::array<int, 3>>&);
template std::vector<float> vertex_normals<float>(const float*, int, const std::vector<std::array<int, 3>>&);

std::vector<float> pattern_texcoords(const std::vector<Vec2>& pattern, double metres_per_unit) {
  std::vector<float> uv(2 * pattern.size());
  for (size_t i = 0; i < pattern.size(); ++i)
    for (int d = 0; d < 2; ++d) uv[2 * i + d] = static_cast<float>(pattern[i][d] / metres_per_unit);
  return uv;
}

namespace {

// A text buffer that numbers are formatted straight into, as fixed-point integers (several
// times faster than printf or the floating-point std::to_chars for the hundreds of thousands
// a large frame holds); `reserve` must be given an upper bound of what follows.
class TextBuffer {
 public:
  static constexpr size_t kNumberChars = 24;  // "-999999999.123456789", "-1.2345678901234567e+308"
  void reserve(size_t more) {
    const size_t used = static_cast<size_t>(end_ - text_.data());
    text_.resize(used + more);
    end_ = text_.data() + used;
  }
  void literal(const char* s) { chars(s, std::strlen(s)); }
  /// `v` with `decimals` digits after the point (at most 9), trailing zeros dropped ("0.25",
  /// "-3", "1.000000001"); at most kNumberChars characters. Beyond 1e9 (or not finite), the
  /// shortest text that reads back as `v`.
  void fixed(double v, int decimals) {
    static constexpr uint64_t kScale[10] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000, 1000000000};
    const double scaled = std::abs(v) * static_cast<double>(kScale[decimals]);
    if (!(std::abs(v) < 1e9)) {
      end_ = std::to_chars(end_, end_ + kNumberChars, v).ptr;
      return;
    }
    const auto q = static_cast<uint64_t>(std::llround(scaled));
    if (v < 0 && q != 0) *end_++ = '-';
    end_ = std::to_chars(end_, end_ + kNumberChars, q / kScale[decimals]).ptr;
    uint64_t fraction = q % kScale[decimals];
    if (fraction == 0) return;
    int digits = decimals;
    while (fraction % 10 == 0) fraction /= 10, --digits;
    *end_++ = '.';
    for (int k = digits - 1; k >= 0; --k, fraction /= 10) end_[k] = static_cast<char>('0' + fraction % 10);
    end_ += digits;
  }
  /// `v` with `significant_digits` significant digits (%g style); at most kNumberChars characters.
  void number(double v, int significant_digits) {
    end_ = std::to_chars(end_, end_ + kNumberChars, v, std::chars_format::general, significant_digits).ptr;
  }
  void put(char c) { *end_++ = c; }
  void chars(const char* s, size_t n) {
    std::memcpy(end_, s, n);
    end_ += n;
  }
  void write_to(std::ostream& out) const {
    out.write(text_.data(), static_cast<std::streamsize>(end_ - text_.data()));
  }

 private:
  std::string text_;
  char* end_ = text_.data();
};

}  // namespace

void write_textured_obj(std::ostream& out, const double* xyz, int vertex_count, const std::vector<float>& texcoords,
                        const std::vector<float>& normals, const std::vector<std::array<int, 3>>& triangles) {
  TextBuffer b;
  // At most kNumberChars characters a number and a separator, 11 an index and its slash, and
  // the keywords.
  constexpr size_t number = TextBuffer::kNumberChars + 1;
  b.reserve(static_cast<size_t>(vertex_count) * (8 * number + 8) + triangles.size() * (9 * 11 + 8));
  for (int i = 0; i < vertex_count; ++i) {
    b.put('v');
    for (int d = 0; d < 3; ++d) b.put(' '), b.fixed(xyz[3 * i + d], 9);
    b.put('\n');
  }
  const bool has_uv = texcoords.size() == 2 * static_cast<size_t>(vertex_count);
  for (int i = 0; has_uv && i < vertex_count; ++i) {
    b.literal("vt ");
    b.fixed(texcoords[2 * i], 7);
    b.put(' ');
    b.fixed(texcoords[2 * i + 1], 7);
    b.put('\n');
  }
  for (int i = 0; i < vertex_count; ++i) {
    b.literal("vn");
    for (int d = 0; d < 3; ++d) b.put(' '), b.fixed(normals[3 * i + d], 7);
    b.put('\n');
  }
  // Each corner is "k/k/k" (or "k//k"): the index formatted once and copied.
  char index[12];
  for (const auto& t : triangles) {
    b.put('f');
    for (int k = 0; k < 3; ++k) {
      const size_t n = static_cast<size_t>(std::to_chars(index, index + sizeof index, t[k] + 1).ptr - index);
      b.put(' ');
      b.chars(index, n);
      b.put('/');
      if (has_uv) b.chars(index, n);
      b.put('/');
      b.chars(index, n);
    }
    b.put('\n');
  }
  b.write_to(out);
}

void write_ply_frame(std::ostream& out, const double* xyz, int vertex_count, const double* added_viscosity,
                     const std::vector<std::array<int, 3>>& triangles) {
  std::ostringstream header;
  header << "ply\nformat ascii 1.0\ncomment weft frame; added_viscosity in N s/m (adaptive damping)\n"
         << "element vertex " << vertex_count << "\nproperty float x\nproperty float y\nproperty float z\n"
         << "property float added_viscosity\nelement face " << triangles.size()
         << "\nproperty list uchar int vertex_indices\nend_header\n";
  TextBuffer b;
  constexpr size_t number = TextBuffer::kNumberChars + 1;
  b.reserve(header.str().size() + static_cast<size_t>(vertex_count) * (4 * number + 2) + triangles.size() * (3 * 11 + 4));
  b.literal(header.str().c_str());
  char index[12];
  for (int i = 0; i < vertex_count; ++i) {
    for (int d = 0; d < 3; ++d) b.fixed(xyz[3 * i + d], 9), b.put(' ');
    // Viscosities span orders of magnitude: significant digits, not decimals.
    b.number(added_viscosity[i], 6);
    b.put('\n');
  }
  for (const auto& t : triangles) {
    b.put('3');
    for (int k = 0; k < 3; ++k) {
      b.put(' ');
      b.chars(index, static_cast<size_t>(std::to_chars(index, index + sizeof index, t[k]).ptr - index));
    }
    b.put('\n');
  }
  b.write_to(out);
}

void AnimatedMesh::add_frame(const double* xyz, int count, const double* viscosity_per_vertex) {
  if (positions.empty() && vertex_count == 0) vertex_count = count;
  if (count != vertex_count) {
    consistent = false;
    return;
  }
  const size_t n = 3 * static_cast<size_t>(count);
  const size_t start = positions.size();
  positions.resize(start + n);
  for (size_t k = 0; k < n; ++k) positions[start + k] = static_cast<float>(xyz[k]);
  if (viscosity_per_vertex) viscosity.insert(viscosity.end(), viscosity_per_vertex, viscosity_per_vertex + count);
}

namespace {

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// The binary chunk of a glb being laid out: each block a bufferView and its accessor, written
// later by its function, so that large data goes from the recorded frames to the file once.
class GlbLayout {
 public:
  nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();

  /// A float accessor of `count` elements of `type` ("SCALAR", "VEC2", "VEC3"); returns its index.
  int add(const char* type, int components, size_t count, int component_type, int target,
          std::function<void(std::ostream&)> write, const std::vector<float>* min_max = nullptr) {
    const size_t bytes = count * static_cast<size_t>(components) * 4;
    nlohmann::json view = {{"buffer", 0}, {"byteOffset", length_}, {"byteLength", bytes}};
    if (target) view["target"] = target;
    views.push_back(view);
    nlohmann::json acc = {{"bufferView", views.size() - 1}, {"componentType", component_type},
                          {"count", count}, {"type", type}};
    if (min_max) {
      acc["min"] = std::vector<float>(min_max->begin(), min_max->begin() + components);
      acc["max"] = std::vector<float>(min_max->begin() + components, min_max->end());
    }
    accessors.push_back(acc);
    blocks_.push_back(std::move(write));
    length_ += bytes;  // every element is 4 bytes: offsets stay 4-byte aligned
    return static_cast<int>(accessors.size()) - 1;
  }
  size_t length() const { return length_; }
  void write(std::ostream& out) const {
    for (const auto& w : blocks_) w(out);
  }

 private:
  size_t length_ = 0;
  std::vector<std::function<void(std::ostream&)>> blocks_;
};

void write_floats(std::ostream& out, const float* data, size_t count) {
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(count * sizeof(float)));
}

// Per-component minimum then maximum of `count` vectors of `components` floats.
std::vector<float> min_max(const float* data, size_t count, int components) {
  std::vector<float> r(2 * static_cast<size_t>(components));
  for (int d = 0; d < components; ++d) r[d] = INFINITY, r[components + d] = -INFINITY;
  for (size_t i = 0; i < count; ++i)
    for (int d = 0; d < components; ++d) {
      const float v = data[i * components + d];
      r[d] = std::min(r[d], v);
      r[components + d] = std::max(r[components + d], v);
    }
  return r;
}

void write_u32(std::ostream& out, uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); }

}  // namespace

void write_glb(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes, const std::vector<double>& frame_times) {
  const size_t frames = frame_times.size();
  GlbLayout layout;
  nlohmann::json j;
  j["asset"] = {{"version", "2.0"}, {"generator", "weft"}};
  j["scene"] = 0;
  j["materials"] = nlohmann::json::array(
      {{{"name", "cloth"}, {"doubleSided", true},
        {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.8, 0.8, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.9}}}}});
  nlohmann::json nodes = nlohmann::json::array(), gltf_meshes = nlohmann::json::array(),
                 channels = nlohmann::json::array(), samplers = nlohmann::json::array();
  std::vector<float> times(frame_times.begin(), frame_times.end()), weights;
  int time_accessor = -1, weight_accessor = -1;
  // Keyframe f shows frame f: morph target f - 1 at weight 1 (frame 0 is the base mesh).
  if (frames > 1) {
    weights.assign(frames * (frames - 1), 0.0f);
    for (size_t f = 1; f < frames; ++f) weights[f * (frames - 1) + f - 1] = 1.0f;
    const auto time_range = min_max(times.data(), frames, 1);
    time_accessor = layout.add("SCALAR", 1, frames, kFloat, 0, [&](std::ostream& o) { write_floats(o, times.data(), frames); },
                               &time_range);
    weight_accessor = layout.add("SCALAR", 1, weights.size(), kFloat, 0,
                                 [&](std::ostream& o) { write_floats(o, weights.data(), weights.size()); });
  }
  // Kept alive until the binary chunk is written.
  std::deque<std::vector<float>> storage;
  auto keep = [&storage](std::vector<float> v) -> const std::vector<float>& { return storage.emplace_back(std::move(v)); };
  std::deque<std::vector<uint32_t>> indices_storage;

  for (const AnimatedMesh* m : meshes) {
    if (!m->consistent || m->vertex_count == 0) continue;
    if (static_cast<size_t>(m->frame_count()) != frames)
      throw std::runtime_error(m->name + ": " + std::to_string(m->frame_count()) + " frames recorded, " +
                               std::to_string(frames) + " frame times");
    const size_t n = static_cast<size_t>(m->vertex_count);
    const float* base = m->positions.data();
    nlohmann::json attributes;
    const auto& base_range = keep(min_max(base, n, 3));
    attributes["POSITION"] = layout.add("VEC3", 3, n, kFloat, kArrayBuffer, [base, n](std::ostream& o) { write_floats(o, base, 3 * n); },
                                        &base_range);
    const auto& base_normals = keep(vertex_normals(base, m->vertex_count, m->triangles));
    attributes["NORMAL"] = layout.add("VEC3", 3, n, kFloat, kArrayBuffer,
                                      [&base_normals, n](std::ostream& o) { write_floats(o, base_normals.data(), 3 * n); });
    if (m->texcoords.size() == 2 * n) {
      std::vector<float> uv(m->texcoords);
      for (size_t i = 0; i < n; ++i) uv[2 * i + 1] = 1.0f - uv[2 * i + 1];
      const auto& gltf_uv = keep(std::move(uv));
      attributes["TEXCOORD_0"] = layout.add("VEC2", 2, n, kFloat, kArrayBuffer,
                                            [&gltf_uv, n](std::ostream& o) { write_floats(o, gltf_uv.data(), 2 * n); });
    }
    float viscosity_peak = 0;
    if (m->viscosity.size() == n * frames) {
      // White where no viscosity was added, through to red at the run's largest value.
      std::vector<float> peak(n, 0.0f);
      for (size_t f = 0; f < frames; ++f)
        for (size_t i = 0; i < n; ++i) peak[i] = std::max(peak[i], m->viscosity[f * n + i]);
      for (float v : peak) viscosity_peak = std::max(viscosity_peak, v);
      std::vector<float> colour(3 * n);
      for (size_t i = 0; i < n; ++i) {
        const float s = viscosity_peak > 0 ? std::clamp(peak[i] / viscosity_peak, 0.0f, 1.0f) : 0.0f;
        colour[3 * i] = 1.0f, colour[3 * i + 1] = 1.0f - 0.85f * s, colour[3 * i + 2] = 1.0f - 0.9f * s;
      }
      const auto& colours = keep(std::move(colour));
      attributes["COLOR_0"] = layout.add("VEC3", 3, n, kFloat, kArrayBuffer,
                                         [&colours, n](std::ostream& o) { write_floats(o, colours.data(), 3 * n); });
    }
    auto& idx = indices_storage.emplace_back();
    idx.reserve(3 * m->triangles.size());
    for (const auto& t : m->triangles)
      for (int k = 0; k < 3; ++k) idx.push_back(static_cast<uint32_t>(t[k]));
    const int index_accessor = layout.add("SCALAR", 1, idx.size(), kUnsignedInt, kElementArrayBuffer, [&idx](std::ostream& o) {
      o.write(reinterpret_cast<const char*>(idx.data()), static_cast<std::streamsize>(idx.size() * 4));
    });
    // Morph targets hold each later frame's displacement from frame 0 and its normals' change,
    // computed as the binary chunk is written (only their bounds are needed before).
    bool any_motion = false;
    for (size_t f = 1; f < frames && !any_motion; ++f) any_motion = !std::equal(base, base + 3 * n, base + 3 * n * f);
    nlohmann::json primitive = {{"attributes", attributes}, {"indices", index_accessor}, {"material", 0}, {"mode", 4}};
    nlohmann::json mesh = {{"name", m->name}};
    if (any_motion) {
      nlohmann::json targets = nlohmann::json::array(), names = nlohmann::json::array();
      for (size_t f = 1; f < frames; ++f) {
        const float* x = base + 3 * n * f;
        std::vector<float> range(6);
        for (int d = 0; d < 3; ++d) range[d] = INFINITY, range[3 + d] = -INFINITY;
        for (size_t i = 0; i < n; ++i)
          for (int d = 0; d < 3; ++d) {
            const float delta = x[3 * i + d] - base[3 * i + d];
            range[d] = std::min(range[d], delta), range[3 + d] = std::max(range[3 + d], delta);
          }
        const auto& delta_range = keep(std::move(range));
        const int position = layout.add("VEC3", 3, n, kFloat, kArrayBuffer, [x, base, n](std::ostream& o) {
          std::vector<float> delta(3 * n);
          for (size_t k = 0; k < 3 * n; ++k) delta[k] = x[k] - base[k];
          write_floats(o, delta.data(), 3 * n);
        }, &delta_range);
        const AnimatedMesh& mesh_ref = *m;
        const int normal = layout.add("VEC3", 3, n, kFloat, kArrayBuffer, [x, n, &mesh_ref, &base_normals](std::ostream& o) {
          std::vector<float> dn = vertex_normals(x, mesh_ref.vertex_count, mesh_ref.triangles);
          for (size_t k = 0; k < 3 * n; ++k) dn[k] -= base_normals[k];
          write_floats(o, dn.data(), 3 * n);
        });
        targets.push_back({{"POSITION", position}, {"NORMAL", normal}});
        names.push_back("frame_" + std::to_string(f));
      }
      primitive["targets"] = targets;
      mesh["weights"] = std::vector<float>(frames - 1, 0.0f);
      mesh["extras"]["targetNames"] = names;
      samplers.push_back({{"input", time_accessor}, {"output", weight_accessor}, {"interpolation", "LINEAR"}});
      channels.push_back({{"sampler", samplers.size() - 1}, {"target", {{"node", nodes.size()}, {"path", "weights"}}}});
    }
    if (viscosity_peak > 0) mesh["extras"]["added_viscosity_peak_N_s_per_m"] = viscosity_peak;
    mesh["primitives"] = nlohmann::json::array({primitive});
    nodes.push_back({{"name", m->name}, {"mesh", gltf_meshes.size()}});
    gltf_meshes.push_back(mesh);
  }
  nlohmann::json scene_nodes = nlohmann::json::array();
  for (size_t k = 0; k < nodes.size(); ++k) scene_nodes.push_back(k);
  j["scenes"] = nlohmann::json::array({{{"name", "weft run"}, {"nodes", scene_nodes}}});
  j["nodes"] = nodes;
  j["meshes"] = gltf_meshes;
  if (!channels.empty()) j["animations"] = nlohmann::json::array({{{"name", "weft run"}, {"channels", channels}, {"samplers", samplers}}});
  // A sampler no channel uses would be left unreferenced: keep the animation data only when played.
  j["buffers"] = nlohmann::json::array({{{"byteLength", layout.length()}}});
  j["bufferViews"] = layout.views;
  j["accessors"] = layout.accessors;

  std::string json_text = j.dump();
  json_text.append((4 - json_text.size() % 4) % 4, ' ');
  const size_t bin_length = layout.length();  // a multiple of 4
  const size_t total = 12 + 8 + json_text.size() + 8 + bin_length;
  if (total > UINT32_MAX) throw std::runtime_error("the glb would take " + std::to_string(total) + " bytes, more than glb's 4 GiB");
  write_u32(out, 0x46546C67);  // "glTF"
  write_u32(out, 2);
  write_u32(out, static_cast<uint32_t>(total));
  write_u32(out, static_cast<uint32_t>(json_text.size()));
  write_u32(out, 0x4E4F534A);  // "JSON"
  out.write(json_text.data(), static_cast<std::streamsize>(json_text.size()));
  write_u32(out, static_cast<uint32_t>(bin_length));
  write_u32(out, 0x004E4942);  // "BIN\0"
  layout.write(out);
}

void write_pc2(std::ostream& out, const AnimatedMesh& mesh) {
  char magic[12] = "POINTCACHE2";  // with its terminating zero: 12 bytes
  out.write(magic, 12);
  const int32_t version = 1, points = mesh.vertex_count, samples = mesh.frame_count();
  const float start_frame = 0.0f, sample_rate = 1.0f;
  out.write(reinterpret_cast<const char*>(&version), 4);
  out.write(reinterpret_cast<const char*>(&points), 4);
  out.write(reinterpret_cast<const char*>(&start_frame), 4);
  out.write(reinterpret_cast<const char*>(&sample_rate), 4);
  out.write(reinterpret_cast<const char*>(&samples), 4);
  write_floats(out, mesh.positions.data(), mesh.positions.size());
}

namespace {

// "(x, y, z)" or "(u, v)": each float in the shortest text that reads back as it.
void append_tuple(std::string& text, const float* v, int components) {
  text += '(';
  for (int d = 0; d < components; ++d) {
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, v[d]).ptr;
    if (d) text += ", ";
    text.append(buffer, end);
  }
  text += ')';
}

// "[(..), (..), ...]" of `count` tuples, 8 to a line after the first.
std::string tuple_array(const float* data, size_t count, int components, const std::string& indent) {
  std::string text = "[";
  for (size_t i = 0; i < count; ++i) {
    if (i) text += i % 8 ? ", " : ",\n" + indent;
    append_tuple(text, data + i * components, components);
  }
  return text + "]";
}

}  // namespace

void write_usda(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes, const std::vector<double>& frame_times) {
  const size_t frames = frame_times.size();
  const double rate = frames > 1 && frame_times.back() > frame_times.front()
                          ? static_cast<double>(frames - 1) / (frame_times.back() - frame_times.front())
                          : 24.0;
  out << "#usda 1.0\n(\n    defaultPrim = \"weft\"\n    doc = \"weft run: the cloth and colliders over the run\"\n"
      << "    metersPerUnit = 1\n    upAxis = \"Y\"\n    startTimeCode = 0\n    endTimeCode = " << (frames ? frames - 1 : 0)
      << "\n    timeCodesPerSecond = " << nlohmann::json(rate).dump() << "\n    framesPerSecond = " << nlohmann::json(rate).dump()
      << "\n)\n\ndef Xform \"weft\"\n{\n";
  for (const AnimatedMesh* m : meshes) {
    if (!m->consistent || m->vertex_count == 0) continue;
    if (static_cast<size_t>(m->frame_count()) != frames)
      throw std::runtime_error(m->name + ": " + std::to_string(m->frame_count()) + " frames recorded, " +
                               std::to_string(frames) + " frame times");
    const size_t n = static_cast<size_t>(m->vertex_count), n3 = 3 * n;
    out << "    def Mesh \"" << m->name << "\"\n    {\n        uniform bool doubleSided = 1\n"
        << "        uniform token orientation = \"rightHanded\"\n        uniform token subdivisionScheme = \"none\"\n"
        << "        int[] faceVertexCounts = [";
    for (size_t t = 0; t < m->triangles.size(); ++t) out << (t ? ", 3" : "3");
    out << "]\n        int[] faceVertexIndices = [";
    for (size_t t = 0; t < m->triangles.size(); ++t)
      out << (t ? ", " : "") << m->triangles[t][0] << ", " << m->triangles[t][1] << ", " << m->triangles[t][2];
    out << "]\n";
    const float* p = m->positions.data();
    bool moves = false;
    for (size_t f = 1; f < frames && !moves; ++f) moves = !std::equal(p, p + n3, p + f * n3);
    if (!moves) {
      out << "        point3f[] points = " << tuple_array(p, n, 3, "            ") << "\n";
    } else {
      out << "        point3f[] points.timeSamples = {\n";
      for (size_t f = 0; f < frames; ++f)
        out << "            " << f << ": " << tuple_array(p + f * n3, n, 3, "                ") << ",\n";
      out << "        }\n";
    }
    if (m->texcoords.size() == 2 * n)
      out << "        texCoord2f[] primvars:st = " << tuple_array(m->texcoords.data(), n, 2, "            ")
          << " (\n            interpolation = \"vertex\"\n        )\n";
    out << "    }\n";
  }
  out << "}\n";
}

void write_rest_obj(std::ostream& out, const AnimatedMesh& mesh) {
  const size_t n = 3 * static_cast<size_t>(mesh.vertex_count);
  const std::vector<double> rest(mesh.positions.begin(), mesh.positions.begin() + static_cast<long>(n));
  write_textured_obj(out, rest.data(), mesh.vertex_count, mesh.texcoords,
                     vertex_normals(rest.data(), mesh.vertex_count, mesh.triangles), mesh.triangles);
}

namespace {
constexpr char kRecordedFramesMagic[16] = "weft frames 1\n";
}  // namespace

void write_recorded_frames(std::ostream& out, const std::vector<const AnimatedMesh*>& meshes,
                           const std::vector<double>& frame_times) {
  out.write(kRecordedFramesMagic, sizeof kRecordedFramesMagic);
  const uint64_t mesh_count = meshes.size(), frame_count = frame_times.size();
  out.write(reinterpret_cast<const char*>(&mesh_count), 8);
  out.write(reinterpret_cast<const char*>(&frame_count), 8);
  out.write(reinterpret_cast<const char*>(frame_times.data()), static_cast<std::streamsize>(8 * frame_count));
  for (const AnimatedMesh* m : meshes) {
    const uint64_t sizes[3] = {static_cast<uint64_t>(m->consistent ? m->vertex_count : -1), m->positions.size(), m->viscosity.size()};
    out.write(reinterpret_cast<const char*>(sizes), sizeof sizes);
    write_floats(out, m->positions.data(), m->positions.size());
    write_floats(out, m->viscosity.data(), m->viscosity.size());
  }
}

void read_recorded_frames(const std::string& bytes, const std::string& file, const std::vector<AnimatedMesh*>& meshes,
                          std::vector<double>& frame_times, size_t frames) {
  size_t at = 0;
  auto take = [&](void* to, size_t n) {
    if (bytes.size() - at < n) throw InputError(file + ": recorded frames are cut short (" + std::to_string(bytes.size()) + " bytes)");
    std::memcpy(to, bytes.data() + at, n);
    at += n;
  };
  char magic[sizeof kRecordedFramesMagic];
  take(magic, sizeof magic);
  if (std::memcmp(magic, kRecordedFramesMagic, sizeof magic) != 0) throw InputError(file + ": not a file of weft's recorded frames");
  uint64_t mesh_count = 0, frame_count = 0;
  take(&mesh_count, 8);
  take(&frame_count, 8);
  if (mesh_count != meshes.size() || frame_count < frames)
    throw InputError(file + ": holds " + std::to_string(frame_count) + " frames of " + std::to_string(mesh_count) +
                     " meshes; the checkpoint needs " + std::to_string(frames) + " of " + std::to_string(meshes.size()));
  if (frame_count > bytes.size() / 8) throw InputError(file + ": recorded frames are cut short");
  frame_times.resize(frame_count);
  take(frame_times.data(), 8 * frame_count);
  frame_times.resize(frames);
  for (AnimatedMesh* m : meshes) {
    uint64_t sizes[3];
    take(sizes, sizeof sizes);
    const bool consistent = sizes[0] != static_cast<uint64_t>(-1);
    const uint64_t n = consistent ? sizes[0] : 0;
    if (consistent && m->vertex_count != 0 && n != static_cast<uint64_t>(m->vertex_count))
      throw InputError(file + ": " + m->name + " has " + std::to_string(n) + " vertices there, " +
                       std::to_string(m->vertex_count) + " in the simulation");
    if (sizes[1] > bytes.size() / 4 || sizes[2] > bytes.size() / 4 || (consistent && sizes[1] != 3 * n * frame_count) ||
        (sizes[2] != 0 && sizes[2] != n * frame_count))
      throw InputError(file + ": the recorded frames of " + m->name + " do not fit their vertex count");
    m->consistent = consistent;
    m->vertex_count = static_cast<int>(n);
    m->positions.resize(sizes[1]);
    take(m->positions.data(), 4 * sizes[1]);
    m->viscosity.resize(sizes[2]);
    take(m->viscosity.data(), 4 * sizes[2]);
    if (consistent) {
      m->positions.resize(3 * n * frames);
      if (!m->viscosity.empty()) m->viscosity.resize(n * frames);
    }
  }
}

}  // namespace weft
