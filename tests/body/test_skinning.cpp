// Skinning: the bind pose reproduces the meshes exactly, DQS agrees with LBS where it must,
// and velocities agree with finite differences of positions.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "body/body_fixture.hpp"
#include "weft/body.hpp"
#include "weft/threads.hpp"

namespace weft {
namespace {

double max_distance(const Points& a, const Points& b) {
  return (a - b).rowwise().norm().maxCoeff();
}

TEST(SkinBindPose, ZeroRotationsReproduceTheRestMesh) {
  // Posing the rig with all-zero Euler angles must leave the A-posed rest mesh where it is.
  const WalkingBody& body = test::shipped_body();
  Rig rig = body.rig();
  nlohmann::json zero = nlohmann::json::object();
  for (const auto& name : rig.bone_names) zero[name] = {0.0, 0.0, 0.0};
  apply_bind_pose(rig, zero, "zero");
  Points lbs, dqs;
  skin_lbs(body.rest_positions(), body.weights(), rig.rest_to_bind, lbs);
  skin_dqs(body.rest_positions(), body.weights(), rig.rest_to_bind, dqs);
  EXPECT_LT(max_distance(lbs, body.rest_positions()), 1e-9);
  EXPECT_LT(max_distance(dqs, body.rest_positions()), 1e-9);
  // ...whereas the T-pose moves the hands by tens of centimetres.
  EXPECT_GT(max_distance(body.bind_positions(), body.rest_positions()), 0.2);
}

TEST(SkinBindPose, ReferenceFrameMotionReproducesTheBindMesh) {
  // A motion that holds the BVH reference pose (every frame = frame 0) must give the bind
  // (T-posed) mesh at every time: retargeting maps the reference pose onto the bind pose
  // (before the limb alignment, tested below).
  const WalkingBody& body = test::shipped_body();
  BvhMotion still = read_bvh(default_motion_file());
  for (int f = 1; f < still.frame_count(); ++f) still.frames.row(f) = still.frames.row(0);
  AnimationOptions options;
  options.align_limbs = false;
  const Animation animation(body.rig(), still, options);
  std::vector<BonePose> poses;
  Points x;
  for (double t : {0.0, 0.37, 1.9, animation.duration_s()}) {
    animation.bone_poses(t, poses);
    for (int b = 0; b < body.rig().bone_count(); ++b)
      poses[b] = poses[b] * body.rig().rest_to_bind[b];
    body.skin(poses, x);
    EXPECT_LT(max_distance(x, body.bind_positions()), 1e-9) << "t = " << t;
  }
}

TEST(SkinDualQuaternion, MatchesLinearBlendOnRigidVerticesAndKeepsScale) {
  const WalkingBody& body = test::shipped_body();
  std::vector<BonePose> poses;
  body.bone_poses(1.3, poses);
  Points lbs, dqs;
  skin_lbs(body.rest_positions(), body.weights(), poses, lbs);
  skin_dqs(body.rest_positions(), body.weights(), poses, dqs);
  int rigid = 0;
  for (Eigen::Index v = 0; v < lbs.rows(); ++v) {
    if (body.weights().weight(v, 0) < 1.0) continue;
    ++rigid;
    EXPECT_LT((lbs.row(v) - dqs.row(v)).norm(), 1e-9);
  }
  EXPECT_GT(rigid, 100);
  // Blended vertices differ (the two methods are not the same formula)...
  EXPECT_GT(max_distance(lbs, dqs), 1e-4);
  // ...and both stay close to each other for a natural pose.
  EXPECT_LT(max_distance(lbs, dqs), 0.05);
}

// Skinning runs its vertices in pieces on every thread allowed; each vertex is its own, so the
// positions are the same bits on one thread and on two, and the same as a vertex skinned alone.
TEST(SkinThreads, TheSameBitsOnOneThreadAndOnTwo) {
  const WalkingBody& body = test::shipped_body();
  std::vector<BonePose> poses;
  body.bone_poses(2.1, poses);
  for (auto skin : {&skin_lbs, &skin_dqs}) {
    Points one, two;
    set_thread_count(1);
    skin(body.rest_positions(), body.weights(), poses, one);
    set_thread_count(2);
    skin(body.rest_positions(), body.weights(), poses, two);
    set_thread_count(0);
    ASSERT_GT(one.rows(), 2048) << "more than two pieces";
    EXPECT_TRUE(one == two);
    // The last vertex (the last, short piece) skinned on its own.
    const Eigen::Index last = one.rows() - 1;
    Points rest_one = body.rest_positions().row(last);
    SkinWeights w;
    w.bone = body.weights().bone.row(last);
    w.weight = body.weights().weight.row(last);
    Points alone;
    skin(rest_one, w, poses, alone);
    EXPECT_TRUE(alone.row(0) == one.row(last));
  }
}

TEST(SkinVelocity, AgreesWithFiniteDifferencesOfPositions) {
  const WalkingBody& body = test::shipped_body();
  const BvhMotion motion = read_bvh(default_motion_file());
  const double interval_s = motion.frame_time_s / 0.75;  // play time between motion frames
  Points v, ahead, behind;
  double fastest = 0;
  for (int k : {3, 40, 111, 200, 310}) {
    const double t = (k + 0.37) * interval_s;  // inside a frame interval, where motion is smooth
    body.velocities(t, v);
    const double h = 0.01 * interval_s;
    body.positions(t + h, ahead);
    body.positions(t - h, behind);
    const Points difference = (ahead - behind) / (2 * h);
    const double speed = v.rowwise().norm().maxCoeff();
    fastest = std::max(fastest, speed);
    EXPECT_LT(max_distance(v, difference), 1e-4 * std::max(1.0, speed)) << "t = " << t;
    EXPECT_TRUE(v.allFinite());
  }
  EXPECT_GT(fastest, 0.5);  // feet and hands move at walking speed or faster
}

TEST(SkinVelocity, MeanVelocityIsTheWalkingSpeed) {
  const WalkingBody& body = test::shipped_body();
  Points start, end, v;
  const double t0 = 1.0, t1 = 3.0;
  body.positions(t0, start);
  body.positions(t1, end);
  Vec3 mean_velocity = Vec3::Zero();
  const int samples = 200;
  for (int i = 0; i < samples; ++i) {
    body.velocities(t0 + (i + 0.5) * (t1 - t0) / samples, v);
    mean_velocity += v.colwise().mean().transpose() / samples;
  }
  const Vec3 travel = (end.colwise().mean() - start.colwise().mean()).transpose();
  EXPECT_NEAR(mean_velocity.z(), travel.z() / (t1 - t0), 0.02 * travel.z() / (t1 - t0));
}

}  // namespace
}  // namespace weft
