// The stability experiment (include/weft/experiments/stability_experiment.hpp): reproducibility,
// physical sanity of a cell, and the command's output and input checks.
#include <gtest/gtest.h>

#include "support/command.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "weft/experiments/stability_experiment.hpp"
#include "weft/error.hpp"
#include "sim/simulation_core.hpp"

namespace {

namespace fs = std::filesystem;
using weft::StabilityExperimentSettings;
using weft::StabilityMethod;

StabilityMethod method(const std::string& name) {
  return weft::parse_stability_methods(name, "--methods").front();
}

TEST(StabilityExperiment, PerturbationIsSeededAndCarriesNoRigidMotion) {
  StabilityExperimentSettings s;
  weft::Simulation sim(weft::stability_scene(s, method("backward-euler"), 0.01, 0.0));
  weft::VecX x1, v1, x2, v2, x3, v3;
  weft::stability_perturbation(s, sim.core().model().mesh, sim.core().model().mass, x1, v1);
  weft::stability_perturbation(s, sim.core().model().mesh, sim.core().model().mass, x2, v2);
  EXPECT_EQ(x1, x2);
  EXPECT_EQ(v1, v2);
  s.seed = 2;
  weft::stability_perturbation(s, sim.core().model().mesh, sim.core().model().mass, x3, v3);
  EXPECT_NE(x1, x3);
  const weft::VecX& m = sim.core().model().mass;
  weft::Vec3 p = weft::Vec3::Zero(), c = weft::Vec3::Zero(), L = weft::Vec3::Zero();
  for (int i = 0; i < m.size(); ++i) {
    p += m[i] * weft::node(v1, i);
    c += m[i] * weft::node(x1, i);
  }
  c /= m.sum();
  for (int i = 0; i < m.size(); ++i) L += m[i] * (weft::node(x1, i) - c).cross(weft::Vec3(weft::node(v1, i)));
  EXPECT_LT(p.norm(), 1e-12);
  EXPECT_LT(L.norm(), 1e-12);
}

TEST(StabilityExperiment, BackwardEulerComesToRestAndForwardEulerBlowsUp) {
  StabilityExperimentSettings s;
  s.duration_s = 3.0;
  const auto be = weft::run_stability_cell(s, method("backward-euler"), 0.02, 0.0);
  EXPECT_TRUE(be.stable);
  EXPECT_GT(be.rest_time, 0.0);
  EXPECT_LE(be.max_energy_ratio, 1.0 + 1e-9);
  const auto fe = weft::run_stability_cell(s, method("forward-euler"), 0.02, 0.05);
  EXPECT_FALSE(fe.stable);
  EXPECT_FALSE(fe.reason.empty());
  EXPECT_LT(fe.unstable_time, 1.0);  // stops at the first instability
}

// Found by the experiment (docs/stability-experiment.md, soft setting): a 0.5 m square, 11x11,
// stretch 50 N/m, shear 5 N/m, dt = 20 ms, largest kappa 160 (the paper's range). Undamped
// Implicit Midpoint blows up within 0.3 s; with 5% adaptive damping the same start stays
// stable, although its energy first rises by about 80% (below the instability threshold of
// twice the initial energy) before it decays. This case is at the edge: with other seeds
// 5% is not enough at this kappa (seeds 2 and 5), or 0% is (seed 4); see the seed table in
// docs/stability-experiment.md. With stretch 500 N/m (kappa 400 and more at
// dt >= 10 ms) 5% does not suffice.
TEST(StabilityExperiment, FivePercentStabilisesImplicitMidpointWhereZeroBlowsUp) {
  StabilityExperimentSettings s;
  s.stretch_modulus_N_m = 50;
  s.shear_modulus_N_m = 5;
  s.duration_s = 1.5;
  const auto undamped = weft::run_stability_cell(s, method("implicit-midpoint-plain"), 0.02, 0.0);
  EXPECT_GT(undamped.kappa_max, 100);
  EXPECT_LT(undamped.kappa_max, 200);
  EXPECT_FALSE(undamped.stable);
  EXPECT_EQ(undamped.reason, "energy");
  const auto damped = weft::run_stability_cell(s, method("implicit-midpoint-plain"), 0.02, 0.05);
  EXPECT_TRUE(damped.stable) << damped.reason << " at " << damped.unstable_time;
  EXPECT_LT(damped.final_energy_ratio, 0.01);
}

TEST(StabilityExperiment, MethodListParsing) {
  const auto m = weft::parse_stability_methods("implicit-midpoint,alpha:2/3,bdf2-alpha,alpha:0.6", "--methods");
  ASSERT_EQ(m.size(), 4u);
  EXPECT_FALSE(m[0].alpha.has_value());
  EXPECT_DOUBLE_EQ(*m[1].alpha, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(*m[2].alpha, 1.0 / std::sqrt(3.0));
  EXPECT_DOUBLE_EQ(*m[3].alpha, 0.6);
  for (const std::string bad : {"euler", "alpha:2/0", "alpha:x", "alpha:1.5", "backward-euler:0.5", "rk4", ""}) {
    try {
      weft::parse_stability_methods(bad, "--methods");
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const weft::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--methods"), std::string::npos) << e.what();
    }
  }
}

class StabilityExperimentCommand : public weft::test::CommandTest {
 protected:
  std::pair<int, std::string> run(const std::string& arguments) {
    const auto r = weft("experiment stability " + arguments);
    return {r.exit_code, r.error_output};
  }
};

TEST_F(StabilityExperimentCommand, ReducedGridWritesCsvAndTables) {
  const fs::path out = folder_ / "out";
  const auto [code, text] = run("--out '" + out.string() +
                                "' --methods backward-euler,implicit-midpoint-plain --dts 0.01,0.02 --ratios 0,0.05 "
                                "--resolution 6 --duration 0.5 -q");
  ASSERT_EQ(code, 0) << text;
  std::ifstream csv(out / "stability.csv");
  std::string line;
  int rows = 0;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("method,alpha,dt,damping_ratio,stable,reason", 0), 0u) << line;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 2 * 2 * 2);
  std::ifstream md(out / "stability.md");
  std::stringstream t;
  t << md.rdbuf();
  EXPECT_NE(t.str().find("### backward Euler"), std::string::npos);
  EXPECT_NE(t.str().find("### Implicit Midpoint"), std::string::npos);
  EXPECT_NE(t.str().find("| 10 ms |"), std::string::npos);
}

TEST_F(StabilityExperimentCommand, BadInputExitsTwoNamingTheOptionAndWritesNothing) {
  const std::string out = " --out '" + (folder_ / "out").string() + "'";
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--resolution 1", "--resolution"}, {"--dts 0.01,-1", "--dts"},     {"--ratios -0.1", "--ratios"},
      {"--methods leapfrog", "--methods"}, {"--duration 0", "--duration"}, {"--size nan", "--size"},
      {"--dts 5 --duration 1", "--dts"}};
  for (const auto& [args, option] : cases) {
    const auto [code, text] = run(args + out);
    EXPECT_EQ(code, 2) << args;
    EXPECT_NE(text.find(option), std::string::npos) << args << ": " << text;
    EXPECT_FALSE(fs::exists(folder_ / "out")) << args;
  }
}

}  // namespace
