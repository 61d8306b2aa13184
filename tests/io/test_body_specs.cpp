// The readers of src/io/body_specs.cpp: the body collider's keys (weft/collider.hpp) and the
// body parts a garment's placement names (weft/placement_spec.hpp), each error naming the key.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "weft/collider.hpp"
#include "weft/error.hpp"
#include "weft/placement_spec.hpp"

namespace weft {
namespace {

std::string error_of(const nlohmann::json& j) {
  try {
    parse_body_collider(j, "scene.json: colliders[0]");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BodyCollider, ParsesAndValidatesKeys) {
  const BodyColliderSpec defaults = parse_body_collider(nlohmann::json{{"type", "body"}}, "c");
  EXPECT_EQ(defaults.motion_file, "");
  EXPECT_EQ(defaults.speed, 0.75);
  EXPECT_EQ(defaults.skinning, "lbs");
  EXPECT_EQ(defaults.start_time, 0.0);
  const BodyColliderSpec spec = parse_body_collider(
      nlohmann::json{{"type", "body"}, {"motion", "walk.bvh"}, {"speed", 1.0},
                     {"skinning", "dqs"}, {"start_time", 0.5}},
      "c");
  EXPECT_EQ(spec.motion_file, "walk.bvh");
  const BodyColliderSpec relative =
      parse_body_collider(nlohmann::json{{"motion", "motions/walk.bvh"}}, "c", "/scenes/coat");
  EXPECT_EQ(relative.motion_file, "/scenes/coat/motions/walk.bvh");
  const BodyColliderSpec absolute =
      parse_body_collider(nlohmann::json{{"motion", "/data/walk.bvh"}}, "c", "/scenes/coat");
  EXPECT_EQ(absolute.motion_file, "/data/walk.bvh");
  EXPECT_EQ(spec.speed, 1.0);
  EXPECT_EQ(spec.skinning, "dqs");
  EXPECT_EQ(spec.start_time, 0.5);

  EXPECT_NE(error_of({{"type", "body"}, {"sped", 1}}).find("\"sped\""), std::string::npos);
  EXPECT_NE(error_of({{"speed", "fast"}}).find("colliders[0].speed"), std::string::npos);
  EXPECT_NE(error_of({{"speed", -1}}).find("colliders[0].speed"), std::string::npos);
  EXPECT_NE(error_of({{"motion", 3}}).find("colliders[0].motion"), std::string::npos);
  EXPECT_NE(error_of({{"skinning", "linear"}}).find("colliders[0].skinning"), std::string::npos);
  EXPECT_NE(error_of({{"start_time", -2}}).find("colliders[0].start_time"), std::string::npos);
  EXPECT_NE(error_of({{"type", "sphere"}}).find("colliders[0].type"), std::string::npos);
  EXPECT_NE(error_of(nlohmann::json::array()).find("colliders[0]"), std::string::npos);
}

TEST(BodyCollider, ArmSpreadIsCheckedAndNamed) {
  EXPECT_DOUBLE_EQ(parse_body_collider(nlohmann::json{{"arm_spread_deg", 20}}, "colliders[0]").arm_spread_deg, 20.0);
  try {
    parse_body_collider(nlohmann::json{{"arm_spread_deg", 60}}, "colliders[0]");
    FAIL() << "accepted 60 degrees";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "colliders[0].arm_spread_deg: must be in [-45, 45] degrees, got 60");
  }
}

TEST(PlacementSpec, BodyPartsAreReadByName) {
  EXPECT_EQ(parse_body_part("left_arm", "x"), BodyPart::kLeftArm);
  try {
    parse_body_part("tail", "placement.sleeve.part");
    FAIL() << "accepted 'tail'";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "placement.sleeve.part: unknown body part \"tail\" (expected torso, left_arm, right_arm, "
                           "left_leg, right_leg or head)");
  }
}

}  // namespace
}  // namespace weft
