// Every shipped pattern that weft sews (docs/garments.md, "Every shipped pattern on the
// mannequin"): `weft garment` at the default 1.5 cm exits 0 with every stitch welded and the
// garment, as written, crossing neither itself nor the body. One test per pattern (slow: up to
// a minute or more of CPU each); the patterns that do not sew yet are named, and a pattern
// added to data/patterns must join one list or the other.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "garment/sample_patterns.hpp"
#include "support/command.hpp"

using weft::test::CommandTest;
using weft::test::read_text;

namespace {

/// The shipped patterns that sew, by file (under data/patterns), and those that do not yet.
const std::set<std::string> kSewing = {
    "coat/coat.json",
    "garment_pattern_generator/dress.json",
    "garment_pattern_generator/jacket.json",
    "garment_pattern_generator/jacket_hood.json",
    "garment_pattern_generator/skirt_4_panels.json",
    "garment_pattern_generator/tee.json",
    "garmentcode/dress_pencil_specification.json",
    "garmentcode/hoody_mean_specification.json",
    "garmentcode/js_mean_all_specification.json",
    "garmentcode/shirt_mean_specification.json",
};
const std::set<std::string> kNotYet = {};

class ShippedGarment : public CommandTest {
 protected:
  void sews(const std::string& file) {
    ASSERT_EQ(kSewing.count(file), 1u) << file;
    const std::string pattern = std::string(WEFT_SOURCE_DIR) + "/data/patterns/" + file;
    const auto out = folder_ / "out";
    const auto r = weft("--threads 1 garment '" + pattern + "' --out '" + out.string() + "'");
    ASSERT_EQ(r.exit_code, 0) << r.error_output;
    const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
    const auto& sewing = summary["sewing"];
    EXPECT_EQ(sewing["sewn"], true);
    EXPECT_TRUE(sewing["open_stitches"].empty());
    EXPECT_LE(sewing["largest_seam_gap_m"].get<double>(), sewing["weld_gap_m"].get<double>());
    EXPECT_EQ(sewing["intersections"]["self"], 0);
    EXPECT_EQ(sewing["intersections"]["body"], 0);
    EXPECT_EQ(sewing["garment"]["non_manifold_edges"], 0);
    EXPECT_TRUE(std::filesystem::exists(out / "garment.obj"));
    EXPECT_FALSE(std::filesystem::exists(out / "garment_unsewn.obj"));
  }
};

TEST(ShippedGarments, EveryShippedPatternIsOneThatSewsOrOneNamedAsNotYet) {
  std::set<std::string> shipped;
  const std::filesystem::path root = std::string(WEFT_SOURCE_DIR) + "/data/patterns";
  for (const std::string& f : weft::test::sample_pattern_files())
    shipped.insert(std::filesystem::relative(f, root).generic_string());
  std::set<std::string> listed = kSewing;
  listed.insert(kNotYet.begin(), kNotYet.end());
  EXPECT_EQ(shipped, listed);
}

TEST_F(ShippedGarment, CoatSews) { sews("coat/coat.json"); }
TEST_F(ShippedGarment, DressSews) { sews("garment_pattern_generator/dress.json"); }
TEST_F(ShippedGarment, JacketSews) { sews("garment_pattern_generator/jacket.json"); }
TEST_F(ShippedGarment, JacketHoodSews) { sews("garment_pattern_generator/jacket_hood.json"); }
TEST_F(ShippedGarment, SkirtFourPanelsSews) { sews("garment_pattern_generator/skirt_4_panels.json"); }
TEST_F(ShippedGarment, TeeSews) { sews("garment_pattern_generator/tee.json"); }
TEST_F(ShippedGarment, DressPencilSews) { sews("garmentcode/dress_pencil_specification.json"); }
TEST_F(ShippedGarment, HoodyMeanSews) { sews("garmentcode/hoody_mean_specification.json"); }
TEST_F(ShippedGarment, ShirtMeanSews) { sews("garmentcode/shirt_mean_specification.json"); }
TEST_F(ShippedGarment, JumpsuitSews) { sews("garmentcode/js_mean_all_specification.json"); }

}  // namespace
