// The rig built from the mesh: joints inside the body, symmetric bones, a real T-pose, weights.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

// Generalised winding number of a closed triangle mesh around point q (1 inside, 0 outside):
// the sum of signed solid angles (Van Oosterom & Strackee) over 4 pi.
double winding_number(const Points& x, const Triangles& tri, const Vec3& q) {
  double total = 0;
  for (Eigen::Index f = 0; f < tri.rows(); ++f) {
    const Vec3 a = x.row(tri(f, 0)).transpose() - q;
    const Vec3 b = x.row(tri(f, 1)).transpose() - q;
    const Vec3 c = x.row(tri(f, 2)).transpose() - q;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2 * std::atan2(numerator, denominator);
  }
  return total / (4 * M_PI);
}

std::string mirror_name(const std::string& name) {
  if (name.rfind("Left", 0) == 0) return "Right" + name.substr(4);
  if (name.rfind("Right", 0) == 0) return "Left" + name.substr(5);
  if (name.rfind("L", 0) == 0 && name.size() > 1 && std::isupper(name[1])) return "R" + name.substr(1);
  if (name.rfind("R", 0) == 0 && name.size() > 1 && std::isupper(name[1])) return "L" + name.substr(1);
  return name;
}

TEST(RigJoints, EveryJointLiesInsideTheBody) {
  const WalkingBody& body = test::shipped_body();
  const Rig& rig = body.rig();
  // The mesh is closed: a point far away has winding number 0, the centre of the pelvis 1.
  EXPECT_NEAR(winding_number(body.rest_positions(), body.triangles(), Vec3(0, 0, 5)), 0.0, 1e-6);
  std::vector<bool> has_child(rig.bone_names.size(), false);
  for (int b = 0; b < rig.bone_count(); ++b)
    if (rig.parent[b] >= 0) has_child[rig.parent[b]] = true;
  for (int b = 0; b < rig.bone_count(); ++b) {
    // Heads are joints; so are the tails of bones that have children. A leaf's tail only marks
    // where the bone ends (top of the head, tip of a toe or finger): it must be near the skin.
    const double w_head = winding_number(body.rest_positions(), body.triangles(), rig.head_rest[b]);
    EXPECT_NEAR(w_head, 1.0, 1e-3) << rig.bone_names[b] << " head " << rig.head_rest[b].transpose();
    if (has_child[b]) {
      const double w_tail =
          winding_number(body.rest_positions(), body.triangles(), rig.tail_rest[b]);
      EXPECT_NEAR(w_tail, 1.0, 1e-3) << rig.bone_names[b] << " tail";
    } else {
      const double nearest =
          (body.rest_positions().rowwise() - rig.tail_rest[b].transpose()).rowwise().norm().minCoeff();
      EXPECT_LT(nearest, 0.02) << rig.bone_names[b] << " tail is far from the skin";
    }
  }
}

TEST(RigJoints, BonesArePositiveAndSymmetric) {
  const Rig& rig = test::shipped_body().rig();
  int pairs = 0;
  for (int b = 0; b < rig.bone_count(); ++b) {
    const double length = (rig.tail_rest[b] - rig.head_rest[b]).norm();
    EXPECT_GT(length, 1e-3) << rig.bone_names[b];
    const std::string other = mirror_name(rig.bone_names[b]);
    if (other == rig.bone_names[b]) continue;
    const int m = rig.find(other);
    ASSERT_GE(m, 0) << "no mirror bone for " << rig.bone_names[b];
    const double mirror_length = (rig.tail_rest[m] - rig.head_rest[m]).norm();
    EXPECT_NEAR(length / mirror_length, 1.0, 0.05) << rig.bone_names[b] << " vs " << other;
    ++pairs;
  }
  EXPECT_GE(pairs, 20);
}

TEST(RigJoints, MeanJointIsTheMeanOfItsVertices) {
  const WalkingBody& body = test::shipped_body();
  const Rig& rig = body.rig();
  const nlohmann::json j = {
      {"Root", {{"parent", ""}, {"head", {{"strategy", "MEAN"}, {"vertex_indices", {0, 5, 9}}}},
                {"tail", {{"strategy", "MEAN"}, {"vertex_indices", {100}}}}}}};
  const Rig small = build_rig(j, ObjMesh{}, body.rest_positions(), "inline");
  const Points& x = body.rest_positions();
  const Vec3 expected = (x.row(0) + x.row(5) + x.row(9)).transpose() / 3.0;
  EXPECT_LT((small.head_rest[0] - expected).norm(), 1e-12);
  EXPECT_LT((small.tail_rest[0] - x.row(100).transpose()).norm(), 1e-12);
  EXPECT_THROW(build_rig(nlohmann::json{{"Root", {{"parent", ""},
                                                  {"head", {{"strategy", "CUBE"}, {"cube_name", "joint-none"}}},
                                                  {"tail", {{"strategy", "MEAN"}, {"vertex_indices", {1}}}}}}},
                         ObjMesh{}, x, "inline"),
               InputError);
  // The shipped rig's neck joint is a MEAN of two body vertices.
  const int neck = rig.find("Neck1");
  ASSERT_GE(neck, 0);
  EXPECT_LT((rig.head_rest[neck] - 0.5 * (x.row(246) + x.row(8263)).transpose()).norm(), 1e-12);
}

TEST(RigBindPose, IsATPose) {
  const Rig& rig = test::shipped_body().rig();
  for (const char* arm : {"LeftArm", "RightArm", "LeftForeArm", "RightForeArm"}) {
    const int b = rig.find(arm);
    const Vec3 rest = (rig.tail_rest[b] - rig.head_rest[b]).normalized();
    const Vec3 bind = (rig.tail_bind[b] - rig.head_bind[b]).normalized();
    EXPECT_LT(rest.y(), -0.4) << arm << " hangs down in the A-pose";
    EXPECT_LT(std::abs(bind.y()), std::sin(10 * M_PI / 180)) << arm << " is horizontal";
  }
  for (const char* leg : {"LeftUpLeg", "RightUpLeg", "LeftLeg", "RightLeg"}) {
    const int b = rig.find(leg);
    const Vec3 bind = (rig.tail_bind[b] - rig.head_bind[b]).normalized();
    EXPECT_LT(bind.y(), -std::cos(10 * M_PI / 180)) << leg << " is vertical";
  }
  // Posing keeps every bone's length.
  for (int b = 0; b < rig.bone_count(); ++b)
    EXPECT_NEAR((rig.tail_bind[b] - rig.head_bind[b]).norm(),
                (rig.tail_rest[b] - rig.head_rest[b]).norm(), 1e-12);
}

TEST(RigWeights, FourLargestRenormalised) {
  const WalkingBody& body = test::shipped_body();
  const SkinWeights& w = body.weights();
  ASSERT_EQ(w.weight.rows(), body.vertex_count());
  for (Eigen::Index v = 0; v < w.weight.rows(); ++v) {
    EXPECT_NEAR(w.weight.row(v).sum(), 1.0, 1e-12);
    for (int k = 0; k < SkinWeights::kInfluences; ++k) {
      EXPECT_GE(w.weight(v, k), 0.0);
      if (k > 0) EXPECT_LE(w.weight(v, k), w.weight(v, k - 1));
    }
  }
  // A vertex with 6 influences keeps its 4 largest.
  Rig rig;
  rig.bone_names = {"a", "b", "c", "d", "e", "f"};
  nlohmann::json j = {{"weights",
                       {{"a", {{0, 0.05}}}, {"b", {{0, 0.3}}}, {"c", {{0, 0.1}}},
                        {"d", {{0, 0.2}}}, {"e", {{0, 0.25}, {7, 1.0}}}, {"f", {{0, 0.1}}}}}};
  const SkinWeights reduced = reduce_weights(j, rig, 1, "inline");
  EXPECT_EQ(reduced.bone(0, 0), 1);
  EXPECT_EQ(reduced.bone(0, 1), 4);
  EXPECT_EQ(reduced.bone(0, 2), 3);
  EXPECT_NEAR(reduced.weight(0, 0), 0.3 / 0.85, 1e-12);
  EXPECT_NEAR(reduced.weight.row(0).sum(), 1.0, 1e-12);
  EXPECT_THROW(reduce_weights(j, rig, 2, "inline"), InputError);  // vertex 1 has no weight
}

}  // namespace
}  // namespace weft

namespace weft {
namespace {

template <class F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(RigInput, WrongTypesAreInputErrorsNotJsonExceptions) {
  // Before, nlohmann's type_error escaped from these and `weft` said "internal error".
  const Points& x = test::shipped_body().rest_positions();
  const nlohmann::json parent_number = {{"Root", {{"parent", 7}}}};
  EXPECT_EQ(input_error_of([&] { build_rig(parent_number, ObjMesh{}, x, "r.json"); }),
            "r.json: bone Root: key parent: expected a string, got 7 (number)");
  const nlohmann::json far_vertex = {{"Root", {{"head", {{"strategy", "MEAN"}, {"vertex_indices", {1e300}}}},
                                               {"tail", {{"strategy", "MEAN"}, {"vertex_indices", {1}}}}}}};
  EXPECT_EQ(input_error_of([&] { build_rig(far_vertex, ObjMesh{}, x, "r.json"); }),
            "r.json: bone Root head: vertex index 1e+300 (number) out of range (expected an integer in [0, " +
                std::to_string(x.rows() - 1) + "])");
  Rig rig;
  rig.bone_names = {"a"};
  rig.parent = {-1};
  EXPECT_EQ(input_error_of([&] { reduce_weights(nlohmann::json{{"weights", {{"a", {{4294967296.5, 1}}}}}}, rig, 1, "w.json"); }),
            "w.json: a: vertex index 4294967296.5 (number) is not a non-negative integer");
  EXPECT_EQ(input_error_of([&] { reduce_weights(nlohmann::json{{"weights", {{"a", {{0, "heavy"}}}}}}, rig, 1, "w.json"); }),
            "w.json: a: weight \"heavy\" (string) is not a number in [0, 1]");
  EXPECT_EQ(input_error_of([&] { reduce_weights(nlohmann::json{{"weights", {{"a", 3}}}}, rig, 1, "w.json"); }),
            "w.json: a: expected an array of [vertex, weight] pairs, got 3 (number)");
  Rig bind = test::shipped_body().rig();
  EXPECT_EQ(input_error_of([&] { apply_bind_pose_file(bind, nlohmann::json{{"rotations", {}}}, "t.json"); }),
            "t.json: expected an object with \"bone_rotations\", got {\"rotations\":null} (object)");
  EXPECT_EQ(input_error_of([&] {
              apply_bind_pose_file(bind, nlohmann::json{{"bone_rotations", {{"LeftArm", {0, "x", 0}}}}}, "t.json");
            }),
            "t.json: LeftArm[1]: expected a number, got \"x\" (string)");
  EXPECT_EQ(input_error_of([&] {
              apply_bind_pose_file(bind, nlohmann::json{{"bone_rotations", {{"LeftArm", {0, 1e300, 0}}}}}, "t.json");
            }),
            "t.json: LeftArm[1]: value 1e+300 is out of range [-6.283185307179586, 6.283185307179586] rad");
}

}  // namespace
}  // namespace weft
