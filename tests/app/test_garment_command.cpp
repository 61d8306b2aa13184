// `weft garment` end to end: every shipped pattern gives the three files, consistent with
// each other; bad input exits 2 with the place named and writes nothing.
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "weft/garment/pattern.hpp"
#include "garment/sample_patterns.hpp"
#include "io/obj_file.hpp"
#include "mesh/mesh.hpp"
#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_text;

namespace {

class GarmentCommand : public CommandTest {
 protected:
  // Built by appending: GCC 12 warns (wrongly) about "'" + string + "'" here.
  std::string quoted(const std::filesystem::path& p) const { return std::string("'").append(p.string()).append("'"); }
};

TEST_F(GarmentCommand, EveryShippedPatternWritesFlatPanelsPictureAndSummary) {
  for (const std::string& file : weft::test::sample_pattern_files()) {
    SCOPED_TRACE(file);
    const weft::Pattern pattern = weft::load_pattern(file);
    const auto out = folder_ / pattern.name;
    const auto r = weft("garment --no-sew " + quoted(file) + " --out " + quoted(out));
    ASSERT_EQ(r.exit_code, 0) << r.error_output;

    const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
    EXPECT_EQ(summary["pattern"], pattern.name);
    EXPECT_EQ(summary["edge_length_m"], 0.015);
    ASSERT_EQ(summary["panels"].size(), pattern.panels.size());
    ASSERT_EQ(summary["stitches"].size(), pattern.stitches.size());
    for (const auto& s : summary["stitches"]) EXPECT_EQ(s["a"]["vertices"], s["b"]["vertices"]);

    // The OBJ: one object per panel, named as in the summary, its triangles and vertices as
    // counted there, flat at z = 0, texture coordinates one per vertex.
    const weft::ObjData obj = weft::parse_obj(read_text(out / "panels.obj"), "panels.obj");
    ASSERT_EQ(obj.groups.size(), pattern.panels.size());
    long triangles = 0;
    for (size_t p = 0; p < obj.groups.size(); ++p) {
      const auto& panel = summary["panels"][p];
      EXPECT_EQ(obj.groups[p].name, pattern.panels[p].name);
      EXPECT_EQ(panel["name"], pattern.panels[p].name);
      EXPECT_EQ(obj.groups[p].end_triangle - obj.groups[p].first_triangle,
                panel["triangles"].get<size_t>());
      triangles += panel["triangles"].get<long>();
    }
    EXPECT_EQ(static_cast<long>(obj.triangles.size()), triangles);
    EXPECT_EQ(summary["triangles"], triangles);
    EXPECT_EQ(obj.vertex_count(), summary["vertices"].get<int>());
    EXPECT_EQ(obj.texcoords.size(), 2 * obj.positions.size() / 3);
    for (int v = 0; v < obj.vertex_count(); ++v)
      ASSERT_EQ(obj.positions[3 * static_cast<size_t>(v) + 2], 0.0);
    for (const auto& t : obj.triangles)
      for (const auto& c : t) ASSERT_EQ(c.texcoord, c.vertex);

    const std::string svg = read_text(out / "panels.svg");
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("</svg>"), std::string::npos);
    for (const auto& panel : pattern.panels)
      EXPECT_NE(svg.find(">" + panel.name + "</text>"), std::string::npos) << panel.name;
  }
}

TEST_F(GarmentCommand, PanelNamesAreEscapedInThePicture) {
  const auto pattern = write("names.json", R"({"properties": {"units_in_meter": 1},
    "pattern": {"panels": {
      "front & <back>": {"vertices": [[0, 0], [0.2, 0], [0.2, 0.2]],
                         "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]}}}})");
  const auto out = folder_ / "out";
  const auto r = weft("garment --no-sew " + quoted(pattern) + " --out " + quoted(out));
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const std::string svg = read_text(out / "panels.svg");
  EXPECT_NE(svg.find(">front &amp; &lt;back&gt;</text>"), std::string::npos);
  EXPECT_EQ(svg.find("front & <back>"), std::string::npos);
  const weft::ObjData obj = weft::parse_obj(read_text(out / "panels.obj"), "panels.obj");
  ASSERT_EQ(obj.groups.size(), 1u);
  EXPECT_EQ(obj.groups[0].name, "front & <back>");
}

TEST_F(GarmentCommand, AnOutputPathThatIsAFileExitsTwo) {
  const auto pattern = write("names.json", R"({"properties": {"units_in_meter": 1},
    "pattern": {"panels": {"a": {"vertices": [[0, 0], [0.2, 0], [0.2, 0.2]],
                                 "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]}}}})");
  const auto file = write("taken", "a file\n");
  const auto r = weft("garment --no-sew " + quoted(pattern) + " --out " + quoted(file));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("exists and is not a folder"), std::string::npos) << r.error_output;
  EXPECT_EQ(read_text(file), "a file\n");
}

TEST_F(GarmentCommand, AStitchNamingAMissingEdgeExitsTwoAndWritesNothing) {
  const auto pattern = write("bad.json", R"({"properties": {"units_in_meter": 1},
    "pattern": {"panels": {
      "a": {"vertices": [[0, 0], [1, 0], [1, 1]], "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]},
      "b": {"vertices": [[0, 0], [1, 0], [1, 1]], "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]}},
    "stitches": [[{"panel": "a", "edge": 1}, {"panel": "b", "edge": 7}]]}})");
  const auto out = folder_ / "out";
  const auto r = weft("garment --no-sew " + quoted(pattern) + " --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("bad.json: key pattern.stitches[0][1].edge: panel 'b' has no edge "
                                "7 (its edges are 0 to 2)"),
            std::string::npos)
      << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(GarmentCommand, AnEdgeLengthOutOfRangeExitsTwo) {
  const std::string jacket =
      std::string(WEFT_SOURCE_DIR) + "/data/patterns/garment_pattern_generator/jacket.json";
  const auto out = folder_ / "out";
  const auto r =
      weft("garment --no-sew " + quoted(jacket) + " --out " + quoted(out) + " --edge-length 0.0001");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(
      r.error_output.find("--edge-length 0.0001: expected a length in metres from 0.002 to 0.5"),
      std::string::npos)
      << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(GarmentCommand, PanelsTakeTheirOwnMaterialAndGrain) {
  const auto pattern = write("two.json", R"({"properties": {"units_in_meter": 1},
    "pattern": {"panels": {
      "a": {"vertices": [[0, 0], [0.2, 0], [0.2, 0.2]], "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]},
      "b": {"vertices": [[0, 0], [0.2, 0], [0.2, 0.2]], "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 0]}]}}}})");
  const auto out = folder_ / "out";
  const auto r = weft("garment --no-sew " + quoted(pattern) + " --out " + quoted(out) +
                      " --panel-material a=denim --panel-grain b=90 --panel-grain a=-30");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(summary["panels"][0]["material"], "denim");
  EXPECT_EQ(summary["panels"][1]["material"], "cotton");
  EXPECT_NEAR(summary["panels"][0]["grain_angle_deg"].get<double>(), -30, 1e-12);
  EXPECT_NEAR(summary["panels"][1]["grain_angle_deg"].get<double>(), 90, 1e-12);

  // A panel the pattern lacks, an unknown preset, a malformed or out-of-range grain: exit 2,
  // the option and value named, nothing written.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--panel-material c=denim", "--panel-material 'c=denim': the pattern " + pattern.string() + " has no panel 'c'"},
      {"--panel-material a=velvet", "--panel-material 'a=velvet': unknown material preset \"velvet\""},
      {"--panel-material denim", "--panel-material 'denim': expected NAME=PRESET"},
      {"--panel-material a=denim --panel-material a=silk", "--panel-material 'a=silk': panel 'a' is given twice"},
      {"--panel-grain a=east", "--panel-grain 'a=east': expected an angle in degrees from -360 to 360"},
      {"--panel-grain a=400", "--panel-grain 'a=400': expected an angle in degrees from -360 to 360"}};
  for (const auto& [option, message] : bad) {
    const auto bad_out = folder_ / "bad_out";
    const auto b = weft("garment --no-sew " + quoted(pattern) + " --out " + quoted(bad_out) + " " + option);
    EXPECT_EQ(b.exit_code, 2) << option;
    EXPECT_NE(b.error_output.find(message), std::string::npos) << option << ": " << b.error_output;
    EXPECT_FALSE(std::filesystem::exists(bad_out)) << option;
  }
}

TEST_F(GarmentCommand, AMissingPatternFileExitsTwo) {
  const auto out = folder_ / "out";
  const auto r = weft("garment --no-sew " + quoted(folder_ / "none.json") + " --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.error_output.find("none.json"), std::string::npos) << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace

namespace {

// The sewn garment end to end, on a GarmentCode shirt at 2 cm (seconds): the seams
// close, the welded mesh is one orientable surface without non-manifold edges, it lies clear
// of itself and the body, and it reads back as a cloth whose triangles keep their panels'
// pattern places (so its area is the panels' area).
TEST_F(GarmentCommand, ASewnShirtIsOneCleanMeshThatReadsBackAsACloth) {
  const std::string shirt =
      std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const auto out = folder_ / "shirt";
  const auto r = weft("garment " + quoted(shirt) + " --out " + quoted(out) + " --edge-length 0.02");
  ASSERT_EQ(r.exit_code, 0) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  ASSERT_EQ(summary["stage"], "sewn");
  const auto& sewing = summary["sewing"];
  EXPECT_LT(sewing["largest_seam_gap_m"].get<double>(), 1e-3);
  EXPECT_GT(sewing["largest_seam_gap_placed_m"].get<double>(), 1e-2);  // the panels did have to move
  EXPECT_EQ(sewing["intersections"]["self"], 0);
  EXPECT_EQ(sewing["intersections"]["body"], 0);
  EXPECT_EQ(sewing["garment"]["non_manifold_edges"], 0);
  EXPECT_EQ(sewing["garment"]["inconsistently_oriented_edges"], 0);
  EXPECT_GT(sewing["garment"]["boundary_edges"].get<int>(), 0);  // neck, hem and cuffs stay open
  EXPECT_NEAR(sewing["garment"]["area_m2"].get<double>(), summary["area_m2"].get<double>(),
              1e-9 * summary["area_m2"].get<double>());
  EXPECT_EQ(sewing["sewn"], true);
  EXPECT_TRUE(sewing["open_stitches"].empty());
  EXPECT_EQ(sewing["garment_file"], "garment.obj");
  EXPECT_FALSE(std::filesystem::exists(out / "garment_unsewn.obj"));
  for (const char* part : {"left_sleeve_f", "left_sleeve_b"}) EXPECT_EQ(sewing["panel_parts"][part], "left_arm");
  EXPECT_EQ(sewing["panel_parts"]["right_ftorso"], "torso");

  // Read back as a cloth mesh: seam vertices have one place per panel, so the mesh keeps
  // them per corner, and the membranes' areas add up to the panels' area.
  const weft::TriMesh mesh = weft::load_obj((out / "garment.obj").string());
  EXPECT_EQ(mesh.num_vertices(), sewing["garment"]["vertices"].get<int>());
  EXPECT_EQ(mesh.corner_pattern.size(), mesh.triangles.size());
  double area = 0;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const weft::Vec2 e1 = mesh.corner(t, 1) - mesh.corner(t, 0), e2 = mesh.corner(t, 2) - mesh.corner(t, 0);
    const double cross = e1.x() * e2.y() - e1.y() * e2.x();
    EXPECT_GT(cross, 0) << "triangle " << t << " is not counter-clockwise in the pattern";
    area += 0.5 * cross;
  }
  EXPECT_NEAR(area, summary["area_m2"].get<double>(), 1e-6 * area);
  const weft::ObjData obj = weft::parse_obj(read_text(out / "garment.obj"), "garment.obj");
  EXPECT_EQ(obj.groups.size(), summary["panels"].size());
}

TEST_F(GarmentCommand, SewingOptionsOutOfRangeExitTwoNamingThem) {
  const std::string shirt =
      std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const auto out = folder_ / "out";
  const std::pair<const char*, const char*> cases[] = {
      {" --clearance 0.5", "--clearance 0.5: expected a gap in metres from 0.002 to 0.2"},
      {" --seam-stiffness -1", "--seam-stiffness -1: expected a stiffness in N/m in (0, 1e7]"},
      {" --sewing-time 0", "--sewing-time 0: expected simulated seconds in (0, 60]"},
      {" --material tweed", "tweed"}};
  for (const auto& [option, message] : cases) {
    const auto r = weft("garment " + quoted(shirt) + " --out " + quoted(out) + option);
    EXPECT_EQ(r.exit_code, 2) << option;
    EXPECT_NE(r.error_output.find(message), std::string::npos) << r.error_output;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace

namespace {

// A garment that does not sew (docs/garments.md, "When a garment does not sew"): two small
// panels, one on each arm, joined by one stitch across the body, sewn for only 20 ms (one
// interval): the seam is still centimetres open when sewing stops, far beyond the weld's 5 mm.
class UnsewnGarment : public GarmentCommand {
 protected:
  std::filesystem::path pattern() {
    return write("apart.json", R"({"properties": {"units_in_meter": 100},
      "pattern": {"panels": {
        "left_sleeve": {"vertices": [[0, 0], [20, 0], [20, 20], [0, 20]],
                        "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}],
                        "translation": [40, 130, 0], "rotation": [0, 0, 0]},
        "right_sleeve": {"vertices": [[0, 0], [20, 0], [20, 20], [0, 20]],
                         "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}],
                         "translation": [-60, 130, 0], "rotation": [0, 0, 0]}},
      "stitches": [[{"panel": "left_sleeve", "edge": 1}, {"panel": "right_sleeve", "edge": 3}]]}})");
  }
  static constexpr const char* kStitch = "stitch 0 (panel 'left_sleeve' edge 1 to panel 'right_sleeve' edge 3): gap ";
};

TEST_F(UnsewnGarment, ExitsSixKeepsItAsGarmentUnsewnAndNamesTheOpenStitch) {
  const auto out = folder_ / "out";
  const std::string args = "garment " + quoted(pattern()) + " --out " + quoted(out) + " --edge-length 0.05 --sewing-time 0.02";
  // With --allow-open-seams: garment.obj on purpose, exit 0, and still said what is open.
  const auto allowed = weft(args + " --allow-open-seams");
  ASSERT_EQ(allowed.exit_code, 0) << allowed.error_output;
  EXPECT_TRUE(std::filesystem::exists(out / "garment.obj"));
  EXPECT_FALSE(std::filesystem::exists(out / "garment_unsewn.obj"));
  EXPECT_NE(allowed.error_output.find(kStitch), std::string::npos) << allowed.error_output;
  EXPECT_NE(allowed.error_output.find("--allow-open-seams"), std::string::npos) << allowed.error_output;

  // Without: exit 6, the garment as garment_unsewn.obj and the garment.obj of the run before
  // gone; the message names the stitch, its gap as in the summary, and what was written.
  const auto r = weft(args);
  ASSERT_EQ(r.exit_code, 6) << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out / "garment.obj"));
  ASSERT_TRUE(std::filesystem::exists(out / "garment_unsewn.obj"));
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  const auto& sewing = summary["sewing"];
  EXPECT_EQ(sewing["sewn"], false);
  EXPECT_EQ(sewing["garment_file"], "garment_unsewn.obj");
  ASSERT_EQ(sewing["open_stitches"].size(), 1u);
  const auto& open = sewing["open_stitches"][0];
  EXPECT_EQ(open["stitch"], 0);
  EXPECT_EQ(open["a"]["panel"], "left_sleeve");
  EXPECT_EQ(open["b"]["panel"], "right_sleeve");
  const double gap = open["gap_m"].get<double>();
  EXPECT_GT(gap, 0.01);  // centimetres open, not a near miss of the weld's 5 mm
  EXPECT_EQ(gap, sewing["largest_seam_gap_per_stitch_m"][0].get<double>());
  char gap_text[64];
  std::snprintf(gap_text, sizeof gap_text, "%.2f mm", 1e3 * gap);
  EXPECT_NE(r.error_output.find(std::string(kStitch) + gap_text), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find("apart did not sew: 1 of 1 stitches left open"), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find((out / "garment_unsewn.obj").string()), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find("no garment.obj"), std::string::npos) << r.error_output;
  // The open stitch is not welded: every panel vertex is still there.
  const weft::TriMesh unsewn = weft::load_obj((out / "garment_unsewn.obj").string());
  EXPECT_EQ(unsewn.num_vertices(), summary["vertices"].get<int>());
  EXPECT_EQ(sewing["garment"]["vertices"], summary["vertices"]);
}

// A pattern that cannot close however long it is sewn: two panels about the torso, a front and
// a back, sewn at both sides and along both their top and their bottom edges, would be a closed
// bag, and the body passes through it (the neck through the top seam, the hips and legs through
// the bottom one). Sewing draws the top round the neck and stalls with both seams centimetres
// open, well within the default sewing time: exit 6, no garment.obj, both stitches named.
TEST_F(UnsewnGarment, ABagTheBodyPassesThroughCannotCloseAndItsStitchesAreNamed) {
  const auto pattern = write("bag.json", R"({"properties": {"units_in_meter": 100},
    "pattern": {"panels": {
      "front": {"vertices": [[-20, 0], [20, 0], [20, 55], [-20, 55]],
                "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}],
                "translation": [0, 90, 20], "rotation": [0, 0, 0]},
      "back": {"vertices": [[-20, 0], [-20, 55], [20, 55], [20, 0]],
               "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}],
               "translation": [0, 90, -20], "rotation": [0, 0, 0]}},
    "stitches": [[{"panel": "front", "edge": 1}, {"panel": "back", "edge": 2}],
                 [{"panel": "front", "edge": 3}, {"panel": "back", "edge": 0}],
                 [{"panel": "front", "edge": 2}, {"panel": "back", "edge": 1}],
                 [{"panel": "front", "edge": 0}, {"panel": "back", "edge": 3}]]}})");
  const auto out = folder_ / "out";
  const auto r = weft("--threads 1 garment " + quoted(pattern) + " --out " + quoted(out) + " --edge-length 0.07");
  ASSERT_EQ(r.exit_code, 6) << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out / "garment.obj"));
  EXPECT_TRUE(std::filesystem::exists(out / "garment_unsewn.obj"));
  EXPECT_NE(r.error_output.find("bag did not sew: "), std::string::npos) << r.error_output;
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  const auto& sewing = summary["sewing"];
  EXPECT_EQ(sewing["sewn"], false);
  EXPECT_LE(sewing["simulated_time_s"].get<double>(), 0.5 + 1e-9);  // the default sewing time
  // The top and bottom seams, each with the body between its two sides (the neck is some 10 cm
  // across): open by centimetres and named on stderr with their panels, edges and gaps.
  for (const auto& [stitch, sides] : {std::pair{2, "stitch 2 (panel 'front' edge 2 to panel 'back' edge 1): gap "},
                                      std::pair{3, "stitch 3 (panel 'front' edge 0 to panel 'back' edge 3): gap "}}) {
    double gap = -1;
    for (const auto& open : sewing["open_stitches"])
      if (open["stitch"] == stitch) gap = open["gap_m"].get<double>();
    EXPECT_GT(gap, 0.03) << "stitch " << stitch;
    char gap_text[64];
    std::snprintf(gap_text, sizeof gap_text, "%.2f mm", 1e3 * gap);
    EXPECT_NE(r.error_output.find(std::string(sides) + gap_text), std::string::npos) << r.error_output;
  }
}

TEST_F(UnsewnGarment, ASceneWhosePatternDoesNotSewIsRefused) {
  const auto scene = [&](const std::string& extra) {
    return write("scene.json", R"({"weft_scene": 1, "duration": 0.01, "frame_interval": 0.01,
      "integrator": {"method": "backward-euler", "dt": 0.005},
      "colliders": [{"type": "body", "bind_pose_hold": 0.5}],
      "cloth": {"material": "cotton", "mesh": {"pattern": {"file": ")" + pattern().string() +
                                                  R"(", "edge_length": 0.05, "sewing_time": 0.02)" + extra + "}}}}");
  };
  const auto out = folder_ / "run";
  const auto r = weft("run " + quoted(scene("")) + " --out " + quoted(out) + " -q");
  EXPECT_EQ(r.exit_code, 6) << r.error_output;
  EXPECT_NE(r.error_output.find("scene.json: cloth.mesh.pattern: apart did not sew"), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find(kStitch), std::string::npos) << r.error_output;
  EXPECT_NE(r.error_output.find("The scene was not run"), std::string::npos) << r.error_output;
  EXPECT_FALSE(std::filesystem::exists(out));
  // allow_open_seams runs it, saying what is open.
  const auto allowed = weft("run " + quoted(scene(R"(, "allow_open_seams": true)")) + " --out " + quoted(out) + " -q");
  EXPECT_EQ(allowed.exit_code, 0) << allowed.error_output;
  EXPECT_NE(allowed.error_output.find(kStitch), std::string::npos) << allowed.error_output;
  EXPECT_TRUE(std::filesystem::exists(out / "frames" / "frame_00001.obj"));
}

}  // namespace
