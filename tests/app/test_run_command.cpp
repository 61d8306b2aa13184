// `weft run` end to end: the files it promises, exit statuses, and error messages that name
// the problem for bad scene files.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "linalg/pcg.hpp"
#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_text;

namespace {

// A small valid scene; `integrator` and `mesh` can be replaced to make it bad.
std::string scene(const std::string& integrator = R"({"method": "implicit-midpoint", "dt": 0.01})",
                  const std::string& mesh = R"({"grid": {"size": [0.2, 0.2], "vertices": [5, 5]}})",
                  const std::string& duration = "0.1") {
  return R"({"weft_scene": 1, "duration": )" + duration + R"(, "frame_interval": 0.02,
  "integrator": )" + integrator + R"(,
  "cloth": {"mesh": )" + mesh + R"(,
            "placement": {"rotation_deg": [-90, 0, 0]},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10, "bending_rigidity": 1e-4},
            "pins": {"grid": [[0, 0], [-1, 0]]}}})";
}

}  // namespace

class RunCommand : public CommandTest {};

TEST_F(RunCommand, WritesFramesEnergyAndSummary) {
  const auto s = write("scene.json", scene());
  const auto out = folder_ / "out";
  const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  // 0.1 s at 0.02 s per frame: frames 0..5, the first at time 0.
  for (int f = 0; f <= 5; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    EXPECT_TRUE(std::filesystem::exists(out / "frames" / name)) << name;
  }
  EXPECT_FALSE(std::filesystem::exists(out / "frames" / "frame_00006.obj"));
  const std::string csv = read_text(out / "energy.csv");
  // The default method is the guarded midpoint: its two guard columns come last.
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "time,kinetic,elastic,gravity,viscous_dissipated,numerical_dissipated,contact_work,total,guard_parts,guard_alpha");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 7);  // header + 6 frames
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  for (const char* key : {"method", "alpha", "dt", "steps", "wall_seconds", "solver_iterations_mean", "status"})
    EXPECT_TRUE(summary.contains(key)) << key;
  EXPECT_EQ(summary["method"], "implicit-midpoint");
  EXPECT_EQ(summary["alpha"], 0.5);
  EXPECT_EQ(summary["steps"], 10);
  EXPECT_EQ(summary["status"], "ok");
  // No temporary file is left behind.
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
}

TEST_F(RunCommand, OverridesApply) {
  const auto s = write("scene.json", scene());
  const auto out = folder_ / "out";
  const auto r = weft("run '" + s.string() + "' --out '" + out.string() +
                      "' --quiet --no-frames --method bdf2-alpha --dt 0.005 --duration 0.04 --damping-ratio 0");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["method"], "bdf2-alpha");
  EXPECT_NEAR(summary["alpha"].get<double>(), 1 / std::sqrt(3.0), 1e-15);
  EXPECT_EQ(summary["steps"], 8);
  EXPECT_EQ(summary["damping_ratio"], 0.0);
  EXPECT_FALSE(std::filesystem::exists(out / "frames" / "frame_00000.obj"));
}

TEST_F(RunCommand, PreconditionerOptionReachesTheSolverAndAllSolveTheSameMotion) {
  // The default scene is small: the automatic choice is SSOR; --preconditioner block-jacobi
  // and multigrid must be used (the summary says so) and give the same motion to the
  // solver's tolerance.
  const std::string sc = std::string(WEFT_SOURCE_DIR) + "/scenes/swing.json";
  const char* names[3] = {"auto", "block-jacobi", "multigrid"};
  nlohmann::json summaries[3];
  std::vector<std::string> last_rows;
  for (int k = 0; k < 3; ++k) {
    const auto out = folder_ / (std::string("pc_") + names[k]);
    const auto r = weft("run '" + sc + "' --out '" + out.string() + "' --quiet --no-frames --duration 0.4 --tolerance 1e-10 --preconditioner " + names[k]);
    ASSERT_EQ(r.exit_code, 0) << r.error_output;
    summaries[k] = nlohmann::json::parse(read_text(out / "summary.json"));
    const std::string csv = read_text(out / "energy.csv");
    last_rows.push_back(csv.substr(csv.rfind('\n', csv.size() - 2) + 1));
  }
  EXPECT_EQ(summaries[0]["preconditioner"], "ssor");
  EXPECT_EQ(summaries[1]["preconditioner"], "block-jacobi");
  EXPECT_EQ(summaries[2]["preconditioner"], "multigrid");
  // SSOR and multigrid need fewer iterations than block-Jacobi at any size (SSOR is a
  // Gauss-Seidel sweep each way, the V-cycle adds coarse corrections to that; both stronger
  // than one Jacobi step).
  const double bj = summaries[1]["solver_iterations_mean"].get<double>();
  EXPECT_LT(summaries[0]["solver_iterations_mean"].get<double>(), bj);
  EXPECT_LT(summaries[2]["solver_iterations_mean"].get<double>(), bj);
  // Same energies at the end (columns printed to 6+ significant digits).
  for (int k : {0, 2}) {
    std::istringstream a(last_rows[k]), b(last_rows[1]);
    std::string fa, fb;
    while (std::getline(a, fa, ',') && std::getline(b, fb, ','))
      EXPECT_NEAR(std::stod(fa), std::stod(fb), 1e-6 + 1e-5 * std::abs(std::stod(fb))) << names[k];
  }
  // The automatic relaxation is the documented function of the free vertices (the default
  // scene: an 11 x 11 grid with two pinned corners); a scene's own value reaches the solver.
  const auto swing = nlohmann::json::parse(read_text(sc));
  const auto& v = swing["cloth"]["mesh"]["grid"]["vertices"];
  const int free = v[0].get<int>() * v[1].get<int>() - static_cast<int>(swing["cloth"]["pins"]["grid"].size());
  EXPECT_DOUBLE_EQ(summaries[0]["ssor_relaxation"].get<double>(), weft::ssor_relaxation_for(free));
  EXPECT_FALSE(summaries[1].contains("ssor_relaxation"));
  EXPECT_EQ(summaries[0]["ssor_precision"], "single") << "the default";
  const auto own = write("ssor.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "preconditioner": "ssor",
                                               "ssor_relaxation": 1.7, "ssor_precision": "double"})"));
  const auto own_out = folder_ / "pc_own";
  const auto r_own = weft("run '" + own.string() + "' --out '" + own_out.string() + "' --quiet --no-frames");
  ASSERT_EQ(r_own.exit_code, 0) << r_own.error_output;
  const auto own_summary = nlohmann::json::parse(read_text(own_out / "summary.json"));
  EXPECT_EQ(own_summary["ssor_relaxation"], 1.7);
  EXPECT_EQ(own_summary["ssor_precision"], "double");
  EXPECT_EQ(own_summary["solver_failures"], 0);
  const auto bad = weft("run '" + sc + "' --out '" + (folder_ / "pc_bad").string() + "' --preconditioner ilu");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.error_output.find("--preconditioner"), std::string::npos) << bad.error_output;
}

TEST_F(RunCommand, BadScenesExitTwoWithAMessageNamingTheProblemAndWriteNothing) {
  struct Case {
    std::string name, text, expected;
  };
  const std::vector<Case> cases{
      {"malformed", "{\"weft_scene\": 1,\n \"duration\": 1,,\n}", ":2: malformed JSON"},
      {"method", scene(R"({"method": "leapfrog", "dt": 0.01})"), "key integrator.method: unknown method 'leapfrog'"},
      {"negative_dt", scene(R"({"method": "implicit-midpoint", "dt": -0.01})"),
       "key integrator.dt: value -0.01 is out of range"},
      {"missing_mesh", scene(R"({"method": "implicit-midpoint", "dt": 0.01})", R"({"obj": "no_such_mesh.obj"})"),
       "no_such_mesh.obj' does not exist"},
      {"unknown_key", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "dtt": 1})"),
       "key integrator.dtt: unknown key"},
      {"wrong_type", scene(R"({"method": "implicit-midpoint", "dt": "fast"})"),
       "key integrator.dt: expected a number, got \"fast\" (string)"},
      {"grid_pattern", scene(R"({"method": "implicit-midpoint", "dt": 0.01})",
                             R"({"grid": {"size": [0.2, 0.2], "vertices": [5, 5], "pattern": "hexagonal"}})"),
       "key cloth.mesh.grid.pattern: unknown grid pattern 'hexagonal'"},
      {"preconditioner", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "preconditioner": "ilu"})"),
       "key integrator.preconditioner: unknown preconditioner 'ilu' (expected auto, block-jacobi, ssor or multigrid)"},
      {"ssor_relaxation", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "ssor_relaxation": 2})"),
       "key integrator.ssor_relaxation: must be in (0, 2), got 2.0"},
      {"ssor_precision", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "ssor_precision": "half"})"),
       "key integrator.ssor_precision: unknown precision 'half' (expected single or double)"},
      {"frame_interval", scene(R"({"method": "implicit-midpoint", "dt": 0.03})"),
       "frame_interval 0.02 s is not a whole number of steps of dt 0.03 s"},
  };
  for (const auto& c : cases) {
    const auto s = write(c.name + ".json", c.text);
    const auto out = folder_ / ("out_" + c.name);
    const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "'");
    EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.error_output;
    EXPECT_NE(r.error_output.find(c.expected), std::string::npos) << c.name << ": " << r.error_output;
    EXPECT_NE(r.error_output.find(s.string()), std::string::npos) << c.name << " should name the file: " << r.error_output;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.name << ": output written for bad input";
  }
  // A degenerate (zero-area) triangle in an OBJ mesh: the error names the scene, the mesh and
  // the triangle.
  write("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
  const auto degenerate = write("degenerate.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01})",
                                                        R"({"obj": "flat.obj"})"));
  std::string text = read_text(degenerate);
  text.replace(text.find(R"("pins": {"grid": [[0, 0], [-1, 0]]})"), std::string(R"("pins": {"grid": [[0, 0], [-1, 0]]})").size(),
               R"("pins": {"vertices": [0]})");
  write("degenerate.json", text);
  auto d = weft("run '" + degenerate.string() + "' --out '" + (folder_ / "out_degenerate").string() + "'");
  EXPECT_EQ(d.exit_code, 2) << d.error_output;
  EXPECT_NE(d.error_output.find("degenerate.json: cloth mesh"), std::string::npos) << d.error_output;
  EXPECT_NE(d.error_output.find("flat.obj: triangle 1 (vertices 0, 1, 3) is degenerate"), std::string::npos)
      << d.error_output;
  EXPECT_FALSE(std::filesystem::exists(folder_ / "out_degenerate"));

  const auto r = weft("run '" + (folder_ / "absent.json").string() + "' --out '" + (folder_ / "o").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("absent.json: cannot open scene file"), std::string::npos) << r.error_output;
}

TEST_F(RunCommand, BadOverridesExitTwo) {
  const auto s = write("scene.json", scene());
  const auto out = folder_ / "out";
  auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --method alpha --alpha 1.5");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("alpha must be in [0, 1], got 1.5"), std::string::npos) << r.error_output;
  r = weft("run '" + s.string() + "' --out '" + out.string() + "' --dt nan");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("dt must be a positive finite number"), std::string::npos) << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(RunCommand, UnstableRunExitsThreeAndKeepsFramesSoFar) {
  // Forward Euler far beyond its stability limit (kappa >> 4).
  const auto s = write("scene.json", scene(R"({"method": "forward-euler", "dt": 0.02})",
                                           R"({"grid": {"size": [0.2, 0.2], "vertices": [9, 9]}})", "2.0"));
  const auto out = folder_ / "out";
  const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet");
  EXPECT_EQ(r.exit_code, 3) << r.error_output;
  EXPECT_NE(r.error_output.find("became unstable"), std::string::npos) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["status"], "unstable");
  const long frames = summary["frames"].get<long>();
  EXPECT_GE(frames, 1);
  EXPECT_LT(frames, 101);
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "frame_00000.obj"));
  const std::string csv = read_text(out / "energy.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), frames + 1);
}

TEST_F(RunCommand, BodyCollidersAreValidatedAndAnimatedAlongsideTheCloth) {
  std::string text = scene();
  // The cloth hangs clear of the body, 2 m to its side.
  const std::string placement = R"("placement": {"rotation_deg": [-90, 0, 0]})";
  text.replace(text.find(placement), placement.size(), R"("placement": {"rotation_deg": [-90, 0, 0], "translation": [2, 1, 0]})");
  text.insert(text.rfind('}'), R"(, "colliders": [{"type": "body", "speed": 0.75}])");
  const auto s = write("scene.json", text);
  const auto out = folder_ / "out";
  auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet --duration 0.04");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "body0_00000.obj"));
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "body0_00002.obj"));

  std::string bad = scene();
  bad.insert(bad.rfind('}'), R"(, "colliders": [{"type": "cylinder"}])");
  const auto b = write("bad.json", bad);
  r = weft("run '" + b.string() + "' --out '" + (folder_ / "bad").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("colliders[0].type: unknown collider type 'cylinder'"), std::string::npos) << r.error_output;
  std::string bad_key = scene();
  bad_key.insert(bad_key.rfind('}'), R"(, "colliders": [{"type": "body", "sped": 1}])");
  const auto k = write("bad_key.json", bad_key);
  r = weft("run '" + k.string() + "' --out '" + (folder_ / "bad_key").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("sped"), std::string::npos) << r.error_output;
}

TEST_F(RunCommand, SolvesStoppedAtTheIterationCapAreReportedOnStderrAndInTheSummary) {
  // One conjugate-gradient iteration cannot reach a relative residual of 1e-10 on a cloth.
  const auto s = write("scene.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01, "max_iterations": 1,
                                               "tolerance": 1e-10})"));
  const auto out = folder_ / "out";
  const auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet");
  EXPECT_EQ(r.exit_code, 0) << r.error_output;
  EXPECT_NE(r.error_output.find("linear solves stopped at the iteration cap of 1"), std::string::npos) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["status"], "solver_capped");
  EXPECT_EQ(summary["solver_failures"], summary["steps"]) << "every solve hit the cap";
  // The default cap leaves the same run ok and quiet.
  const auto fine = write("fine.json", scene());
  const auto ok = weft("run '" + fine.string() + "' --out '" + out.string() + "' --quiet");
  EXPECT_EQ(ok.exit_code, 0);
  EXPECT_EQ(ok.error_output, "");
  EXPECT_EQ(nlohmann::json::parse(read_text(out / "summary.json"))["status"], "ok");
}

TEST_F(RunCommand, StabilityAdviceNamesOnlyChangesFromTheSettingsInForce) {
  // scenes/swing-21x21.json blows up under the plain Implicit Midpoint step at dt = 20 ms with
  // the default 5% damping (docs/results.md).
  const std::string sc = std::string(WEFT_SOURCE_DIR) + "/scenes/swing-21x21.json";
  const auto r = weft("run '" + sc + "' --method implicit-midpoint-plain --out '" + (folder_ / "out").string() +
                      "' --quiet --no-frames");
  ASSERT_EQ(r.exit_code, 3) << r.error_output;
  const std::string& e = r.error_output;
  EXPECT_EQ(e.find("--damping-ratio 0.05"), std::string::npos) << e;
  EXPECT_NE(e.find("more damping than the current ratio of 0.05 (e.g. --damping-ratio 0.1)"), std::string::npos) << e;
  EXPECT_NE(e.find("a smaller time step than the current 0.02 s (e.g. --dt 0.01)"), std::string::npos) << e;
  EXPECT_NE(e.find("--method backward-euler"), std::string::npos) << e;
  EXPECT_NE(e.find("the guarded step (--method implicit-midpoint)"), std::string::npos) << e;
  EXPECT_NE(e.find("Newton iterations within each step, for a fabric that stiffens (e.g. --newton 4)"),
            std::string::npos) << e;
  // Forward Euler without damping: adaptive damping is off, so turning it on is the advice.
  const auto s = write("scene.json", scene(R"({"method": "forward-euler", "dt": 0.02})",
                                           R"({"grid": {"size": [0.2, 0.2], "vertices": [9, 9]}})", "2.0"));
  const auto fe = weft("run '" + s.string() + "' --out '" + (folder_ / "fe").string() + "' --quiet");
  ASSERT_EQ(fe.exit_code, 3);
  EXPECT_NE(fe.error_output.find("adaptive damping, off now (e.g. --damping-ratio 0.05)"), std::string::npos)
      << fe.error_output;
  EXPECT_EQ(fe.error_output.find("guarded"), std::string::npos) << fe.error_output;  // none for it
  EXPECT_EQ(fe.error_output.find("--newton"), std::string::npos) << fe.error_output;  // nor iterations
}

TEST_F(RunCommand, AnOutputFolderNeverMixesTwoRuns) {
  const auto s = write("scene.json", scene());
  const auto out = folder_ / "out";
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet").exit_code, 0);
  ASSERT_TRUE(std::filesystem::exists(out / "frames" / "frame_00005.obj"));
  // Files weft did not write stay.
  write("out/notes.txt", "mine");
  write("out/frames/frame_notes.txt", "mine too");
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet --no-frames").exit_code, 0);
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    left.push_back(std::filesystem::relative(e.path(), out).string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"energy.csv", "frames", "frames/frame_notes.txt", "notes.txt", "summary.json"}));
  // A shorter run with frames leaves none of the longer run's later frames.
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet").exit_code, 0);
  ASSERT_EQ(weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet --duration 0.04").exit_code, 0);
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "frame_00002.obj"));
  EXPECT_FALSE(std::filesystem::exists(out / "frames" / "frame_00003.obj"));
}

TEST_F(RunCommand, AnOutputThatCannotBeWrittenExitsFourAndSaysWhatWasKept) {
  // A file-size limit (ulimit -f, in 512-byte blocks; it binds root too) makes writes fail
  // part-way as a full disk does: a 21 x 21 PLY frame (about 23 kB) fits under 64 blocks, the
  // checkpoint of the same cloth (positions, velocities and the solution history: over
  // 33 kB) does not. (An OBJ frame, with texture coordinates and normals, is larger than the
  // first checkpoint.)
  const auto s = write("scene.json", scene(R"({"method": "implicit-midpoint", "dt": 0.01})",
                                           R"({"grid": {"size": [0.2, 0.2], "vertices": [21, 21]}})"));
  const auto out = folder_ / "out";
  auto r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet --checkpoint-every 0 --format ply", "ulimit -f 64;");
  EXPECT_EQ(r.exit_code, 4) << r.error_output;
  const std::string checkpoint = (out / "checkpoint.weft").string();
  EXPECT_NE(r.error_output.find("could not write " + checkpoint), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find("Kept: frames 0 in " + (out / "frames").string() +
                                ", energy.csv (1 row), summary.json (status output_failed)"),
            std::string::npos) << r.error_output;
  auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["status"], "output_failed");
  EXPECT_NE(summary["message"].get<std::string>().find(checkpoint), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "frame_00000.ply"));
  EXPECT_FALSE(std::filesystem::exists(out / "frames" / "frame_00001.ply"));
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();

  // A limit below a frame's size: the first frame fails, energy.csv and summary.json are kept.
  r = weft("run '" + s.string() + "' --out '" + out.string() + "' --quiet", "ulimit -f 16;");
  EXPECT_EQ(r.exit_code, 4) << r.error_output;
  EXPECT_NE(r.error_output.find("could not write " + (out / "frames" / "frame_00000.obj").string()), std::string::npos)
      << r.error_output;
  EXPECT_NE(r.error_output.find("Kept: no frames, energy.csv (1 row), summary.json"), std::string::npos) << r.error_output;
  summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["status"], "output_failed");
}
