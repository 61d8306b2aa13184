#pragma once
// The shipped body data, read once, for the harnesses of the body's readers.
#include <nlohmann/json.hpp>
#include <string>

#include "fuzz_common.hpp"
#include "io/json_util.hpp"
#include "weft/body.hpp"
#include "weft/material.hpp"

namespace weft::fuzz {

inline std::string body_dir() { return data_dir() + "/body/"; }

inline const ObjMesh& shipped_body() {
  static const ObjMesh body = read_obj(body_dir() + "body_tri_m.obj");
  return body;
}

inline const ObjMesh& shipped_joint_cubes() {
  static const ObjMesh cubes = read_obj(body_dir() + "joint_cubes.obj");
  return cubes;
}

inline Rig shipped_rest_rig() {
  const std::string path = body_dir() + "rig.cmu_mb.json";
  return build_rig(json_util::load_json_file(path, "rig"), shipped_joint_cubes(), shipped_body().positions, path);
}

inline Rig shipped_bind_rig() {
  Rig rig = shipped_rest_rig();
  const std::string path = body_dir() + "t-pose.cmu_mb.json";
  apply_bind_pose_file(rig, json_util::load_json_file(path, "t-pose"), path);
  return rig;
}

}  // namespace weft::fuzz
