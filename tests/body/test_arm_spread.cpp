// AnimationOptions::arm_spread_rad turns each arm rigidly about its shoulder, by the angle given,
// away from the body; nothing else of the pose changes.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

// 1 for bones in the subtree of `root_name` (itself included), else 0.
std::vector<char> subtree(const Rig& rig, const std::string& root_name) {
  const int root = rig.find(root_name);
  std::vector<char> in(rig.bone_names.size(), 0);
  for (int b = 0; b < rig.bone_count(); ++b)
    for (int a = b; a >= 0; a = rig.parent[a])
      if (a == root) in[b] = 1;
  return in;
}

TEST(ArmSpread, TurnsEachArmRigidlyAboutItsShoulderAwayFromTheBody) {
  const Rig& rig = test::shipped_body().rig();
  const BvhMotion motion = read_bvh(default_motion_file());
  const double angle = 0.2;
  AnimationOptions spread_options;
  spread_options.arm_spread_rad = angle;
  const Animation plain(rig, motion, {}), spread(rig, motion, spread_options);
  const std::vector<char> left = subtree(rig, "LeftArm"), right = subtree(rig, "RightArm");
  for (double t : {0.3, 1.1, 2.4}) {
    std::vector<BonePose> a, b;
    plain.bone_poses(t, a);
    spread.bone_poses(t, b);
    for (const auto* side : {&left, &right}) {
      const int shoulder = rig.find(side == &left ? "LeftArm" : "RightArm");
      const Eigen::Quaterniond turn = b[shoulder].rotation * a[shoulder].rotation.conjugate();
      EXPECT_NEAR(Eigen::AngleAxisd(turn).angle(), angle, 1e-9) << "t = " << t;
      const Vec3 pivot = a[shoulder].apply(rig.head_bind[shoulder]);
      EXPECT_LT((b[shoulder].apply(rig.head_bind[shoulder]) - pivot).norm(), 1e-12);
      for (int k = 0; k < rig.bone_count(); ++k) {
        if (!(*side)[k]) continue;
        // The same turn about the shoulder for every bone of the arm: a rigid motion.
        EXPECT_LT((b[k].rotation * a[k].rotation.conjugate()).angularDistance(turn), 1e-9) << rig.bone_names[k];
        const Vec3 head = a[k].apply(rig.head_bind[k]);
        EXPECT_LT((b[k].apply(rig.head_bind[k]) - (pivot + turn * (head - pivot))).norm(), 1e-9) << rig.bone_names[k];
      }
    }
    for (int k = 0; k < rig.bone_count(); ++k) {
      if (left[k] || right[k]) continue;
      EXPECT_LT(b[k].rotation.angularDistance(a[k].rotation), 1e-12) << rig.bone_names[k];
      EXPECT_LT((b[k].translation - a[k].translation).norm(), 1e-12) << rig.bone_names[k];
    }
    // Away from the body: the hands end farther apart.
    const int lh = rig.find("LeftHand"), rh = rig.find("RightHand");
    const double apart_plain = (a[lh].apply(rig.head_bind[lh]) - a[rh].apply(rig.head_bind[rh])).norm();
    const double apart_spread = (b[lh].apply(rig.head_bind[lh]) - b[rh].apply(rig.head_bind[rh])).norm();
    EXPECT_GT(apart_spread, apart_plain + 0.05) << "t = " << t;
  }
}

}  // namespace
}  // namespace weft
