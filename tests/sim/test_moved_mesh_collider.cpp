// A mesh collider moved from code (Simulation::move_collider) in one of two simulations of one
// shared Model: its surface follows the pose collider_pose reports, the other simulation's
// stays where the scene put it, and the cloth it lifts ends as under the same keyframes given
// in the scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "weft/scene.hpp"
#include "weft/simulation.hpp"

using namespace weft;

namespace {

// A 0.3 m sheet lying 4 mm above the top of a closed 0.4 m box mesh (top at y = 0).
Scene sheet_on_a_box(bool keyframes) {
  const std::string dir = testing::TempDir() + "weft_moved_mesh_collider_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/box.obj") << "v -0.2 -0.1 -0.2\nv 0.2 -0.1 -0.2\nv 0.2 -0.1 0.2\nv -0.2 -0.1 0.2\n"
                                     "v -0.2 0 -0.2\nv 0.2 0 -0.2\nv 0.2 0 0.2\nv -0.2 0 0.2\n"
                                     "f 5 8 7\nf 5 7 6\nf 1 2 3\nf 1 3 4\nf 4 3 7\nf 4 7 8\n"
                                     "f 1 5 6\nf 1 6 2\nf 2 6 7\nf 2 7 3\nf 1 4 8\nf 1 8 5\n";
  nlohmann::json j = nlohmann::json::parse(R"({
    "weft_scene": 1, "duration": 0.06, "frame_interval": 0.02,
    "integrator": {"method": "implicit-midpoint", "dt": 0.005},
    "cloth": {"mesh": {"grid": {"size": [0.3, 0.3], "vertices": [9, 9]}},
              "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.15, 0.004, 0.15]},
              "self_collision": false},
    "colliders": [{"type": "mesh", "obj": "box.obj", "closed": true}]
  })");
  if (keyframes)
    j["colliders"][0]["motion"] = nlohmann::json::parse(
        R"({"keyframes": [{"time": 0, "translation": [0, 0, 0]}, {"time": 0.04, "translation": [0.01, 0.02, 0]}]})");
  return parse_scene(j, dir + "/s.json", dir);
}

}  // namespace

TEST(MovedMeshCollider, ItsSurfaceFollowsItsPoseInOneOfTwoSimulationsOfAModel) {
  const auto model = std::make_shared<const Model>(sheet_on_a_box(false));
  Simulation still(model), moved(model);
  Eigen::Isometry3d lift = Eigen::Isometry3d::Identity();
  lift.translation() = Vec3(0.01, 0.02, 0);
  moved.move_collider(0, lift, 0.04);
  Simulation keyed(sheet_on_a_box(true));
  Points rest, p_still, p_moved;
  Triangles tri;
  still.collider_surface(0, 0.0, rest, tri);
  for (double t : {0.02, 0.04, 0.06}) {
    SCOPED_TRACE(t);
    still.advance_to(t);
    moved.advance_to(t);
    keyed.advance_to(t);
    Triangles ts, tm;
    still.collider_surface(0, t, p_still, ts);
    moved.collider_surface(0, t, p_moved, tm);
    const Eigen::Isometry3d pose = moved.collider_pose(0, t);
    EXPECT_LT((pose.translation() - std::min(t / 0.04, 1.0) * lift.translation()).norm(), 1e-15);
    EXPECT_EQ(still.collider_pose(0, t).matrix(), Eigen::Matrix4d::Identity()) << "the other simulation's collider";
    ASSERT_EQ(p_moved.rows(), rest.rows());
    for (Eigen::Index v = 0; v < rest.rows(); ++v) {
      EXPECT_LT((Vec3(p_moved.row(v).transpose()) - pose * Vec3(rest.row(v).transpose())).norm(), 1e-15) << "vertex " << v;
      EXPECT_EQ(p_still.row(v), rest.row(v)) << "vertex " << v;
    }
  }
  // The lifted box carried the cloth up; the still one did not, and the same keyframes in the
  // scene move the cloth to the same bits.
  double lowest_moved = 1, highest_still = -1;
  for (int i = 0; i < moved.vertex_count(); ++i) {
    lowest_moved = std::min(lowest_moved, node(moved.positions(), i).y());
    highest_still = std::max(highest_still, node(still.positions(), i).y());
  }
  EXPECT_GT(lowest_moved, 0.02) << "the cloth rests on the lifted top";
  EXPECT_LT(highest_still, 0.01);
  EXPECT_EQ(moved.positions(), keyed.positions());
}
