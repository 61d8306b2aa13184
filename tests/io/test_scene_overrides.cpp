// apply_overrides (weft/scene.hpp): the settings `weft run`'s options replace, validated by the
// library so that every caller gets the same errors.
#include <gtest/gtest.h>

#include <string>

#include "weft/error.hpp"
#include "weft/scene.hpp"

using namespace weft;

namespace {

Scene small_scene() {
  return parse_scene_text(R"({"weft_scene": 1, "duration": 0.1, "frame_interval": 0.02,
    "integrator": {"method": "implicit-midpoint", "dt": 0.01},
    "cloth": {"mesh": {"grid": {"size": [1, 1], "vertices": [3, 3]}}}})",
                          "s.json", ".");
}

std::string override_error(const SceneOverrides& o) {
  Scene s = small_scene();
  try {
    apply_overrides(s, o, "command line");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SceneOverrides, NoOverrideLeavesTheSceneAsItWas) {
  const Scene before = small_scene();
  Scene after = before;
  apply_overrides(after, {}, "command line");
  EXPECT_EQ(after.method_name, before.method_name);
  EXPECT_EQ(after.integrator.alpha, before.integrator.alpha);
  EXPECT_EQ(after.integrator.dt, before.integrator.dt);
  EXPECT_EQ(after.duration, before.duration);
  EXPECT_EQ(after.integrator.cg_tolerance, before.integrator.cg_tolerance);
  EXPECT_EQ(after.integrator.newton_iterations, before.integrator.newton_iterations);
  EXPECT_FALSE(after.integrator.preconditioner.has_value());
  EXPECT_FALSE(after.damping_ratio.has_value());
}

TEST(SceneOverrides, EachOverrideReplacesItsSetting) {
  Scene s = small_scene();
  SceneOverrides o;
  o.method = "backward-euler";
  o.dt = 0.005;
  o.duration = 0.04;
  o.tolerance = 1e-8;
  o.damping_ratio = 0.1;
  o.newton = 3;
  o.preconditioner = "multigrid";
  apply_overrides(s, o, "command line");
  EXPECT_EQ(s.method_name, "backward-euler");
  EXPECT_EQ(s.integrator.alpha, 1.0);  // the method fixes it
  EXPECT_EQ(s.integrator.dt, 0.005);
  EXPECT_EQ(s.duration, 0.04);
  EXPECT_EQ(s.integrator.cg_tolerance, 1e-8);
  EXPECT_EQ(*s.damping_ratio, 0.1);
  EXPECT_EQ(s.integrator.newton_iterations, 3);
  EXPECT_EQ(*s.integrator.preconditioner, Preconditioner::kMultigrid);
}

TEST(SceneOverrides, TheToleranceIsTheLocalErrorsForRk45) {
  Scene s = small_scene();
  const double cg_before = s.integrator.cg_tolerance;
  SceneOverrides o;
  o.method = "rk45";
  o.tolerance = 1e-4;
  apply_overrides(s, o, "command line");
  EXPECT_EQ(s.integrator.error_tolerance, 1e-4);
  EXPECT_EQ(s.integrator.cg_tolerance, cg_before);
}

TEST(SceneOverrides, AnAlphaAloneKeepsTheScenesMethod) {
  Scene s = small_scene();
  s.method_name = "alpha";
  SceneOverrides o;
  o.alpha = 0.7;
  apply_overrides(s, o, "command line");
  EXPECT_EQ(s.method_name, "alpha");
  EXPECT_EQ(s.integrator.alpha, 0.7);
}

TEST(SceneOverrides, BadOverridesNameTheOptionAndTheValue) {
  SceneOverrides newton;
  newton.newton = 1.5;
  EXPECT_EQ(override_error(newton), "command line: --newton 1.5: expected an integer from 0 to 100");
  newton.newton = 101;
  EXPECT_EQ(override_error(newton), "command line: --newton 101.0: expected an integer from 0 to 100");
  SceneOverrides preconditioner;
  preconditioner.preconditioner = "jacobi";
  EXPECT_EQ(override_error(preconditioner),
            "command line: --preconditioner 'jacobi': expected auto, block-jacobi, ssor or multigrid");
  SceneOverrides method;
  method.method = "leapfrog";
  EXPECT_EQ(override_error(method).rfind("command line: unknown method 'leapfrog'", 0), 0u) << override_error(method);
  SceneOverrides dt;
  dt.dt = 0.003;  // 0.02 s frames are not a whole number of 3 ms steps
  EXPECT_EQ(override_error(dt), "command line: frame_interval 0.02 s is not a whole number of steps of dt 0.003 s");
  // A duration between two frames would be cut to the earlier one (below one frame, to
  // nothing): refused, with the two whole numbers of frames either side.
  SceneOverrides duration;
  duration.duration = 0.05;
  EXPECT_EQ(override_error(duration), "command line: duration 0.05 s is not a whole number of frame_interval 0.02 s "
                                      "(2.5 frames); frames are written at whole intervals, so choose 0.04 or 0.06 s");
  duration.duration = 0.01;
  EXPECT_EQ(override_error(duration), "command line: duration 0.01 s is not a whole number of frame_interval 0.02 s "
                                      "(0.5 frames); frames are written at whole intervals, so choose 0.02 s");
  duration.duration = 0.3;  // 15 frames of 0.02 s, though 0.3 / 0.02 is not exactly 15 in binary
  EXPECT_EQ(override_error(duration), "");
  SceneOverrides damping;
  damping.damping_ratio = -0.1;
  EXPECT_EQ(override_error(damping), "command line: damping ratio must be in [0, 10], got -0.1");
}
