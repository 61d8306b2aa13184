// The mannequin walking the shipped motion: sane, grounded, forward, alternating feet.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double ma = 0, mb = 0;
  for (size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    ab += (a[i] - ma) * (b[i] - mb);
    aa += (a[i] - ma) * (a[i] - ma);
    bb += (b[i] - mb) * (b[i] - mb);
  }
  return ab / std::sqrt(aa * bb);
}

TEST(BodyWalk, StaysWholeGroundedAndWalksForward) {
  const WalkingBody& body = test::shipped_body();
  const Rig& rig = body.rig();
  EXPECT_GT(body.duration_s(), 3.5);  // 2.98 s of motion played at 0.75x
  EXPECT_LT(body.duration_s(), 4.5);

  // Edge lengths of the rest mesh, to see that skinning keeps the surface together.
  const Triangles& tri = body.triangles();
  auto edge_lengths = [&](const Points& x) {
    VecX lengths(3 * tri.rows());
    for (Eigen::Index f = 0; f < tri.rows(); ++f)
      for (int k = 0; k < 3; ++k)
        lengths[3 * f + k] = (x.row(tri(f, k)) - x.row(tri(f, (k + 1) % 3))).norm();
    return lengths;
  };
  const VecX rest_edges = edge_lengths(body.rest_positions());

  const int feet[2] = {rig.find("LeftFoot"), rig.find("RightFoot")};
  const int toes[2] = {rig.find("LeftToeBase"), rig.find("RightToeBase")};
  const int hands[2] = {rig.find("LeftHand"), rig.find("RightHand")};
  const int shoulders[2] = {rig.find("LeftArm"), rig.find("RightArm")};
  std::vector<double> foot_height[2];
  double toe_ahead = 0;
  Points x;
  std::vector<BonePose> poses;
  double floor_first = 0;
  Vec3 hips_first = Vec3::Zero(), hips_last = Vec3::Zero();
  const double fps = 60;
  const int frames = static_cast<int>(body.duration_s() * fps) + 1;
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    body.bone_poses(t, poses);
    body.skin(poses, x);
    ASSERT_TRUE(x.allFinite()) << "t = " << t;
    ASSERT_EQ(x.rows(), body.vertex_count());
    const double lowest = x.col(1).minCoeff();
    if (f == 0) floor_first = lowest;
    EXPECT_GT(lowest, floor_first - 0.02) << "t = " << t;
    // Skinning bends the surface without tearing it: linear blending does squeeze and stretch
    // a few short edges in the armpits (also in the bind pose), but no edge explodes and
    // almost all keep their length within a factor 2.
    const VecX ratio = edge_lengths(x).cwiseQuotient(rest_edges);
    const VecX strain = ratio.cwiseMax(ratio.cwiseInverse());
    EXPECT_LT(strain.maxCoeff(), 20.0) << "t = " << t;
    EXPECT_LT((strain.array() > 2.0).count(), strain.size() / 200) << "t = " << t;
    for (int s = 0; s < 2; ++s) {
      const Vec3 ankle = poses[feet[s]].apply(rig.head_rest[feet[s]]);
      const Vec3 toe = poses[toes[s]].apply(rig.tail_rest[toes[s]]);
      foot_height[s].push_back(ankle.y());
      toe_ahead += (toe - ankle).z();
      // Arms hang down while walking (they are horizontal in the bind pose).
      const Vec3 hand = poses[hands[s]].apply(rig.head_rest[hands[s]]);
      const Vec3 shoulder = poses[shoulders[s]].apply(rig.head_rest[shoulders[s]]);
      EXPECT_LT(hand.y(), shoulder.y() - 0.3) << "t = " << t;
    }
    const Vec3 hips = poses[0].apply(rig.head_rest[0]);
    // Upright, and the left leg stays on the left (+X when facing +Z with Y up).
    const int head = rig.find("Head");
    EXPECT_GT(poses[head].apply(rig.head_rest[head]).y(), hips.y() + 0.5) << "t = " << t;
    EXPECT_GT(poses[feet[0]].apply(rig.head_rest[feet[0]]).x(),
              poses[feet[1]].apply(rig.head_rest[feet[1]]).x())
        << "t = " << t;
    if (f == 0) hips_first = hips;
    hips_last = hips;
  }
  EXPECT_GT(toe_ahead, 0) << "feet point the way the body walks (+Z)";
  const Vec3 travel = hips_last - hips_first;
  EXPECT_GT(travel.z(), 3.0);
  EXPECT_LT(travel.z(), 5.0);
  EXPECT_LT(std::abs(travel.x()), 0.1 * travel.z());  // straight ahead
  EXPECT_LT(correlation(foot_height[0], foot_height[1]), 0.0);
}

TEST(BodyWalk, ReferencePoseAlignsLimbsOnly) {
  // Holding the performer's reference pose: limb segments point where the performer's do,
  // every other bone keeps its bind orientation.
  const WalkingBody& body = test::shipped_body();
  const Rig& rig = body.rig();
  BvhMotion still = read_bvh(default_motion_file());
  for (int f = 1; f < still.frame_count(); ++f) still.frames.row(f) = still.frames.row(0);
  const Animation animation(rig, still, {});
  std::vector<BonePose> poses;
  animation.bone_poses(0.5, poses);
  std::vector<Eigen::Quaterniond> world(still.joints.size());
  for (size_t j = 0; j < still.joints.size(); ++j) {
    const int p = still.joints[j].parent;
    world[j] = p < 0 ? still.local_rotation(0, j) : world[p] * still.local_rotation(0, j);
  }
  int limbs = 0;
  for (int b = 0; b < rig.bone_count(); ++b) {
    const std::string& name = rig.bone_names[b];
    const Vec3 posed = poses[b].rotation * (rig.tail_bind[b] - rig.head_bind[b]);
    if (name.ends_with("Leg") || name.ends_with("Arm")) {
      const int j = still.find(name);
      const int child = still.find(name.ends_with("UpLeg")     ? name.substr(0, name.size() - 5) + "Leg"
                                   : name.ends_with("Leg")     ? name.substr(0, name.size() - 3) + "Foot"
                                   : name.ends_with("ForeArm") ? name.substr(0, name.size() - 7) + "Hand"
                                                               : name.substr(0, name.size() - 3) + "ForeArm");
      ASSERT_GE(child, 0) << name;
      const Vec3 performer = world[j] * still.joints[child].offset;
      EXPECT_LT((posed.normalized() - performer.normalized()).norm(), 1e-9) << name;
      ++limbs;
    } else {
      EXPECT_LT(poses[b].rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-9) << name;
    }
  }
  EXPECT_EQ(limbs, 8);
}

TEST(BodyWalk, SpeedScaleAndStartTimeRemapTime) {
  const WalkingBody& slow = test::shipped_body();  // speed 0.75
  BodyColliderSpec spec;
  spec.speed = 1.5;
  spec.start_time = 0.3;
  const WalkingBody fast(spec);
  // At 1.5x, play time t shows motion time 0.3 + 1.5 t, which the 0.75x body shows at
  // (0.3 + 1.5 t) / 0.75.
  EXPECT_NEAR(fast.duration_s(), (slow.duration_s() * 0.75 - 0.3) / 1.5, 1e-9);
  Points a, b, va, vb;
  for (double t : {0.0, 0.4, 1.1}) {
    fast.positions(t, a);
    slow.positions((0.3 + 1.5 * t) / 0.75, b);
    EXPECT_LT((a - b).rowwise().norm().maxCoeff(), 1e-9) << "t = " << t;
  }
  // Velocities scale with the speed: twice as fast as the 0.75x body at the same motion time.
  const double t = 0.5 + 0.37 / 180;
  fast.velocities(t, va);
  slow.velocities((0.3 + 1.5 * t) / 0.75, vb);
  EXPECT_LT((va - 2 * vb).rowwise().norm().maxCoeff(), 1e-3 * va.rowwise().norm().maxCoeff());
}

TEST(BodyWalk, DualQuaternionSkinningWalksToo) {
  BodyColliderSpec spec;
  spec.skinning = "dqs";
  const WalkingBody body(spec);
  Points x, y;
  body.positions(2.0, x);
  test::shipped_body().positions(2.0, y);
  EXPECT_TRUE(x.allFinite());
  EXPECT_GT((x - y).rowwise().norm().maxCoeff(), 1e-5);  // really a different method
  EXPECT_LT((x - y).rowwise().norm().maxCoeff(), 0.05);  // of the same pose
}

}  // namespace
}  // namespace weft

namespace weft {
namespace {

TEST(BodyWalk, MotionAtAnAbsurdScaleIsRefused) {
  // A skeleton a nanometre tall would scale the root's travel by about 1e9 and carry the body
  // out of any scene: refused as bad input, naming the scale.
  const char* text =
      "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
      "JOINT LeftUpLeg\n{\nOFFSET 0 -1e-9 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 -1e-9 0\n}\n}\n}\n"
      "MOTION\nFrames: 3\nFrame Time: 0.1\n0 0 0 0 0 0\n0 0 0 0 0 0\n1 0 0 0 0 0\n";
  std::istringstream in(text);
  const BvhMotion motion = parse_bvh(in, "tiny.bvh");
  try {
    Animation animation(test::shipped_body().rig(), motion, {});
    FAIL() << "accepted a skeleton 2e-9 units tall";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("m per unit, outside [1e-4, 1e4]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace weft
