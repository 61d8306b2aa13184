// The rig: joints computed from the mesh, the T-pose bind pose, and skinning weights.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <nlohmann/json.hpp>

#include "io/json_util.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

// MakeHuman's base.obj is in decimetres.
constexpr double kBaseObjUnit_m = 0.1;

// Blender's axes in ours: Blender (x, y, z) = our (x, -z, y), i.e. ours = S * Blender.
Mat3 blender_to_ours() {
  Mat3 s;
  s << 1, 0, 0,  //
      0, 0, 1,   //
      0, -1, 0;
  return s;
}

// A bone's rest frame as Blender builds it (vec_roll_to_mat3): the shortest rotation taking
// +Y onto the bone direction, then a roll about the bone. `direction` in Blender axes.
Mat3 blender_bone_frame(const Vec3& direction, double roll_rad) {
  const Vec3 n = direction.normalized();
  const double x = n.x(), y = n.y(), z = n.z();
  Mat3 b = Mat3::Identity();
  double theta = 1.0 + y;
  const double theta_alt = x * x + z * z;
  if (theta > 6.1e-3 || theta_alt > 2.5e-4 * 2.5e-4) {
    if (theta <= 6.1e-3) theta = theta_alt * 0.5 + theta_alt * theta_alt * 0.125;
    // Columns are the images of the bone's local x, y, z axes.
    b.col(0) << 1 - x * x / theta, -x, -x * z / theta;
    b.col(1) << x, y, z;
    b.col(2) << -x * z / theta, -z, 1 - z * z / theta;
  } else {
    b(0, 0) = -1;
    b(1, 1) = -1;
  }
  return Eigen::AngleAxisd(roll_rad, n).toRotationMatrix() * b;
}

/// Most bones a rig may have (the CMU rig has 31).
constexpr size_t kMaxBones = 1000;
/// Largest magnitude of a bind-pose Euler angle or a bone roll (rad).
constexpr double kMaxAngle_rad = 2 * M_PI;

/// `key` of the object `j` as a string, or `fallback` when absent.
std::string string_field(const nlohmann::json& j, const char* key, const std::string& where,
                         const std::string& fallback) {
  if (!j.contains(key)) return fallback;
  const auto& v = j[key];
  if (!v.is_string()) throw InputError(where + ": key " + key + ": expected a string, got " + json_util::describe(v));
  return v.get<std::string>();
}

/// A number within [-limit, limit] (`what` and `unit` for messages).
double bounded_number(const nlohmann::json& v, double limit, const std::string& where, const std::string& unit) {
  if (!v.is_number()) throw InputError(where + ": expected a number, got " + json_util::describe(v));
  const double x = v.get<double>();
  if (!(std::abs(x) <= limit))
    throw InputError(where + ": value " + v.dump() + " is out of range " + json_util::range_text(-limit, limit, unit));
  return x;
}

Vec3 joint_position(const nlohmann::json& end, const std::map<std::string, Vec3>& cubes,
                    const Points& body_m, const std::string& where) {
  if (!end.is_object()) throw InputError(where + ": expected an object, got " + json_util::describe(end));
  const std::string strategy = string_field(end, "strategy", where, "");
  if (strategy == "CUBE") {
    const std::string name = string_field(end, "cube_name", where, "");
    auto it = cubes.find(name);
    if (it == cubes.end()) throw InputError(where + ": joint cube '" + name + "' not found");
    return it->second;
  }
  if (strategy == "MEAN") {
    if (!end.contains("vertex_indices") || !end["vertex_indices"].is_array() ||
        end["vertex_indices"].empty())
      throw InputError(where + ": MEAN needs a non-empty vertex_indices list");
    Vec3 sum = Vec3::Zero();
    for (const auto& v : end["vertex_indices"]) {
      const std::optional<long> i = json_util::integer_value(v);
      if (!i || *i < 0 || *i >= body_m.rows())
        throw InputError(where + ": vertex index " + json_util::describe(v) + " out of range (expected an integer in [0, " +
                         std::to_string(body_m.rows() - 1) + "])");
      sum += body_m.row(*i).transpose();
    }
    return sum / static_cast<double>(end["vertex_indices"].size());
  }
  throw InputError(where + ": unknown joint strategy '" + strategy + "' (expected CUBE or MEAN)");
}

}  // namespace

int Rig::find(const std::string& name) const {
  auto it = std::find(bone_names.begin(), bone_names.end(), name);
  return it == bone_names.end() ? -1 : static_cast<int>(it - bone_names.begin());
}

Rig build_rig(const nlohmann::json& rig_json, const ObjMesh& joint_cubes_dm, const Points& body_m,
              const std::string& where) {
  if (!rig_json.is_object() || rig_json.empty())
    throw InputError(where + ": expected an object of bones");
  if (rig_json.size() > kMaxBones)
    throw InputError(where + ": " + std::to_string(rig_json.size()) + " bones, more than the " +
                     std::to_string(kMaxBones) + " a rig may have");
  std::map<std::string, Vec3> cubes;
  for (size_t g = 0; g < joint_cubes_dm.group_names.size(); ++g) {
    const auto& vertices = joint_cubes_dm.group_vertices[g];
    if (vertices.empty()) continue;
    Vec3 sum = Vec3::Zero();
    for (int v : vertices) sum += joint_cubes_dm.positions.row(v).transpose();
    cubes[joint_cubes_dm.group_names[g]] = sum * (kBaseObjUnit_m / vertices.size());
  }

  // Order bones so that parents precede children (depth first from the roots, by name).
  std::map<std::string, std::vector<std::string>> children;
  std::vector<std::string> roots;
  for (const auto& [name, bone] : rig_json.items()) {
    if (!bone.is_object())
      throw InputError(where + ": bone " + name + ": expected an object, got " + json_util::describe(bone));
    const std::string parent = string_field(bone, "parent", where + ": bone " + name, "");
    if (parent.empty()) {
      roots.push_back(name);
    } else {
      if (!rig_json.contains(parent))
        throw InputError(where + ": bone " + name + " has unknown parent '" + parent + "'");
      children[parent].push_back(name);
    }
  }
  if (roots.size() != 1) throw InputError(where + ": expected exactly one root bone");
  Rig rig;
  std::function<void(const std::string&, int)> visit = [&](const std::string& name, int parent) {
    const auto& bone = rig_json[name];
    const std::string bone_where = where + ": bone " + name;
    rig.bone_names.push_back(name);
    rig.parent.push_back(parent);
    rig.roll_rad.push_back(bone.contains("roll") ? bounded_number(bone["roll"], kMaxAngle_rad, bone_where + " roll", "rad") : 0.0);
    for (const char* end : {"head", "tail"})
      if (!bone.contains(end)) throw InputError(bone_where + ": key " + end + " missing");
    rig.head_rest.push_back(joint_position(bone["head"], cubes, body_m, bone_where + " head"));
    rig.tail_rest.push_back(joint_position(bone["tail"], cubes, body_m, bone_where + " tail"));
    if (rig.head_rest.back() == rig.tail_rest.back())
      throw InputError(bone_where + ": head and tail are at the same place (a bone needs a length)");
    const int self = rig.bone_count() - 1;
    for (const auto& child : children[name]) visit(child, self);
  };
  visit(roots.front(), -1);
  if (rig.bone_count() != static_cast<int>(rig_json.size()))
    throw InputError(where + ": bone hierarchy has a cycle");
  rig.head_bind = rig.head_rest;
  rig.tail_bind = rig.tail_rest;
  rig.rest_to_bind.assign(rig.bone_names.size(), BonePose{});
  return rig;
}

void apply_bind_pose(Rig& rig, const nlohmann::json& bone_rotations, const std::string& where) {
  if (!bone_rotations.is_object()) throw InputError(where + ": bone_rotations must be an object");
  const Mat3 s = blender_to_ours();
  std::vector<Mat3> local(rig.bone_names.size(), Mat3::Identity());
  for (const auto& [name, angles] : bone_rotations.items()) {
    const int b = rig.find(name);
    if (b < 0) throw InputError(where + ": unknown bone '" + name + "'");
    if (!angles.is_array() || angles.size() != 3)
      throw InputError(where + ": " + name + " needs 3 Euler angles, got " + json_util::describe(angles));
    Vec3 a;
    for (int k = 0; k < 3; ++k)
      a[k] = bounded_number(angles[k], kMaxAngle_rad, where + ": " + name + "[" + std::to_string(k) + "]", "rad");
    // Blender's XYZ Euler order: X applied first, so R = Rz Ry Rx.
    local[b] = (Eigen::AngleAxisd(a[2], Vec3::UnitZ()) * Eigen::AngleAxisd(a[1], Vec3::UnitY()) *
                Eigen::AngleAxisd(a[0], Vec3::UnitX()))
                   .toRotationMatrix();
  }
  // World rotation of bone b: D_b = D_parent C_b P_b C_b^T (C_b the rest frame, P_b the local
  // pose rotation); a bone's head moves rigidly with its parent.
  std::vector<Mat3> world(rig.bone_names.size());
  for (int b = 0; b < rig.bone_count(); ++b) {
    const int p = rig.parent[b];
    const Vec3 direction_blender = s.transpose() * (rig.tail_rest[b] - rig.head_rest[b]);
    const Mat3 frame = s * blender_bone_frame(direction_blender, rig.roll_rad[b]);
    const Mat3 parent_world = p < 0 ? Mat3::Identity() : world[p];
    world[b] = parent_world * frame * local[b] * frame.transpose();
    rig.head_bind[b] = p < 0 ? rig.head_rest[b]
                             : Vec3(rig.head_bind[p] +
                                    parent_world * (rig.head_rest[b] - rig.head_rest[p]));
    rig.tail_bind[b] = rig.head_bind[b] + world[b] * (rig.tail_rest[b] - rig.head_rest[b]);
    Eigen::Quaterniond q(world[b]);
    q.normalize();
    rig.rest_to_bind[b] = {q, rig.head_bind[b] - q * rig.head_rest[b]};
  }
}

void apply_bind_pose_file(Rig& rig, const nlohmann::json& pose_json, const std::string& where) {
  if (!pose_json.is_object() || !pose_json.contains("bone_rotations"))
    throw InputError(where + ": expected an object with \"bone_rotations\", got " + json_util::describe(pose_json));
  apply_bind_pose(rig, pose_json["bone_rotations"], where);
}

SkinWeights reduce_weights(const nlohmann::json& weights_json, const Rig& rig, int vertex_count,
                           const std::string& where) {
  const nlohmann::json& table =
      weights_json.contains("weights") ? weights_json["weights"] : weights_json;
  if (!table.is_object()) throw InputError(where + ": expected a \"weights\" object");
  std::vector<std::vector<std::pair<double, int>>> influences(static_cast<size_t>(vertex_count));
  for (const auto& [name, list] : table.items()) {
    const int b = rig.find(name);
    if (b < 0) throw InputError(where + ": weights for unknown bone '" + name + "'");
    if (!list.is_array())
      throw InputError(where + ": " + name + ": expected an array of [vertex, weight] pairs, got " +
                       json_util::describe(list));
    for (const auto& entry : list) {
      if (!entry.is_array() || entry.size() != 2)
        throw InputError(where + ": " + name + ": expected [vertex, weight] pairs, got " + json_util::describe(entry));
      const std::optional<long> v = json_util::integer_value(entry[0]);
      if (!v || *v < 0)
        throw InputError(where + ": " + name + ": vertex index " + json_util::describe(entry[0]) +
                         " is not a non-negative integer");
      if (!entry[1].is_number() || !(entry[1].get<double>() >= 0 && entry[1].get<double>() <= 1))
        throw InputError(where + ": " + name + ": weight " + json_util::describe(entry[1]) + " is not a number in [0, 1]");
      const double w = entry[1].get<double>();
      if (*v < vertex_count && w > 0) influences[*v].emplace_back(w, b);
    }
  }
  SkinWeights out;
  out.bone.setZero(vertex_count, SkinWeights::kInfluences);
  out.weight.setZero(vertex_count, SkinWeights::kInfluences);
  for (int v = 0; v < vertex_count; ++v) {
    auto& list = influences[v];
    if (list.empty())
      throw InputError(where + ": vertex " + std::to_string(v) + " has no skinning weight");
    // Largest first; ties broken by bone index so the result does not depend on file order.
    std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    const int n = std::min<int>(SkinWeights::kInfluences, static_cast<int>(list.size()));
    double total = 0;
    for (int k = 0; k < n; ++k) total += list[k].first;
    for (int k = 0; k < n; ++k) {
      out.bone(v, k) = list[k].second;
      out.weight(v, k) = list[k].first / total;
    }
  }
  return out;
}

}  // namespace weft
