// The rig: joints computed from the mesh, the T-pose bind pose, and skinning weights.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>

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

Vec3 joint_position(const nlohmann::json& end, const std::map<std::string, Vec3>& cubes,
                    const Points& body_m, const std::string& where) {
  const std::string strategy = end.value("strategy", "");
  if (strategy == "CUBE") {
    const std::string name = end.value("cube_name", "");
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
      const int i = v.get<int>();
      if (i < 0 || i >= body_m.rows())
        throw InputError(where + ": vertex index " + std::to_string(i) + " out of range");
      sum += body_m.row(i).transpose();
    }
    return sum / static_cast<double>(end["vertex_indices"].size());
  }
  throw InputError(where + ": unknown joint strategy '" + strategy + "'");
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
    const std::string parent = bone.value("parent", "");
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
    rig.roll_rad.push_back(bone.value("roll", 0.0));
    rig.head_rest.push_back(joint_position(bone.at("head"), cubes, body_m, bone_where + " head"));
    rig.tail_rest.push_back(joint_position(bone.at("tail"), cubes, body_m, bone_where + " tail"));
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
      throw InputError(where + ": " + name + " needs 3 Euler angles");
    // Blender's XYZ Euler order: X applied first, so R = Rz Ry Rx.
    local[b] = (Eigen::AngleAxisd(angles[2].get<double>(), Vec3::UnitZ()) *
                Eigen::AngleAxisd(angles[1].get<double>(), Vec3::UnitY()) *
                Eigen::AngleAxisd(angles[0].get<double>(), Vec3::UnitX()))
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

SkinWeights reduce_weights(const nlohmann::json& weights_json, const Rig& rig, int vertex_count,
                           const std::string& where) {
  const nlohmann::json& table =
      weights_json.contains("weights") ? weights_json["weights"] : weights_json;
  if (!table.is_object()) throw InputError(where + ": expected a \"weights\" object");
  std::vector<std::vector<std::pair<double, int>>> influences(static_cast<size_t>(vertex_count));
  for (const auto& [name, list] : table.items()) {
    const int b = rig.find(name);
    if (b < 0) throw InputError(where + ": weights for unknown bone '" + name + "'");
    for (const auto& entry : list) {
      if (!entry.is_array() || entry.size() != 2)
        throw InputError(where + ": " + name + ": expected [vertex, weight] pairs");
      const int v = entry[0].get<int>();
      const double w = entry[1].get<double>();
      if (v < 0) throw InputError(where + ": " + name + ": negative vertex index");
      if (v < vertex_count && w > 0) influences[v].emplace_back(w, b);
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
