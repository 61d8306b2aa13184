// Sewing's building blocks: a mesh cut into pattern pieces (per-corner pattern coordinates)
// bends exactly as the uncut mesh, a seam is a zero-length spring, placement rolls panels onto
// the body's cylinders without stretching them and keeps them off the body, and welding merges
// every stitch's pairs into a consistently oriented mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "collision/intersections.hpp"
#include "placed_lengths.hpp"
#include "weft/garment/placement.hpp"
#include "weft/garment/sewing.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

Material fabric() { return material_preset("cotton"); }

/// A grid whose pattern is cut along the column i = cut: every triangle right of it has its
/// corners' pattern places turned by `angle` and moved by `shift` (a second piece), the
/// vertices on the cut taking both places.
TriMesh cut_grid(int nu, int nv, int cut, double angle, const Vec2& shift) {
  TriMesh m = make_grid(0.3, 0.2, nu, nv);
  const Eigen::Rotation2Dd R(angle);
  m.corner_pattern.resize(m.triangles.size());
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    int right = 0;
    for (int k = 0; k < 3; ++k) right += m.triangles[t][k] % nu > cut ? 1 : 0;
    for (int k = 0; k < 3; ++k) {
      const Vec2 p = m.pattern[m.triangles[t][k]];
      m.corner_pattern[t][k] = right > 0 ? Vec2(R * p + shift) : p;
    }
  }
  // A curved, stretched state so that bending and membranes both work.
  for (int i = 0; i < m.num_vertices(); ++i) {
    const double u = m.positions(i, 0);
    m.positions(i, 2) = 0.05 * std::sin(7 * u) + 0.01 * m.positions(i, 1);
  }
  return m;
}

TEST(SewnMesh, APatternCutIntoPiecesBendsAndStretchesAsTheWholeOne) {
  TriMesh curved = cut_grid(13, 9, 6, 0.0, Vec2::Zero());
  curved.corner_pattern.clear();
  // Turned by a half turn: the weft and warp keep their axes (cotton bends unequally along them).
  const TriMesh cut = cut_grid(13, 9, 6, M_PI, Vec2(0.7, -0.4));
  ASSERT_FALSE(cut.corner_pattern.empty());
  const ClothModel a = build_cloth_model(curved, fabric(), Vec3::Zero(), {});
  const ClothModel b = build_cloth_model(cut, fabric(), Vec3::Zero(), {});
  ASSERT_EQ(a.bending.size(), b.bending.size());
  ASSERT_EQ(a.bending_slot_q.size(), b.bending_slot_q.size());
  double scale = 0;
  for (double q : a.bending_slot_q) scale = std::max(scale, std::abs(q));
  for (size_t s = 0; s < a.bending_slot_q.size(); ++s) EXPECT_NEAR(a.bending_slot_q[s], b.bending_slot_q[s], 1e-9 * scale);
  for (size_t t = 0; t < a.membranes.size(); ++t) EXPECT_NEAR(a.membranes[t].area, b.membranes[t].area, 1e-15);
  ClothSystem sa(a, {}), sb(b, {});
  Evaluation ea, eb;
  const VecX x = a.initial_positions(), v = VecX::Zero(x.size());
  sa.evaluate(x, v, false, ea);
  sb.evaluate(x, v, false, eb);
  EXPECT_NEAR(ea.elastic_energy, eb.elastic_energy, 1e-9 * std::abs(ea.elastic_energy));
  EXPECT_GT(ea.elastic_energy, 0);
  EXPECT_LE((ea.force - eb.force).cwiseAbs().maxCoeff(), 1e-9 * ea.force.cwiseAbs().maxCoeff());
}

TEST(SewnMesh, ASeamIsAZeroLengthSpring) {
  TriMesh m = make_grid(0.1, 0.1, 3, 3);
  const double k = 250;
  const ClothModel plain = build_cloth_model(m, fabric(), Vec3::Zero(), {});
  const ClothModel sewn = build_cloth_model(m, fabric(), Vec3::Zero(), {}, BendingModel::kHinge, {{0, 8, k}});
  ClothSystem a(plain, {}), b(sewn, {});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> d(-0.01, 0.01);
  VecX x = plain.initial_positions();
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] += d(rng);
  const VecX v = VecX::Zero(x.size());
  Evaluation ea, eb;
  a.evaluate(x, v, true, ea);
  b.evaluate(x, v, true, eb);
  const Vec3 gap = x.segment<3>(0) - x.segment<3>(24);
  EXPECT_NEAR(eb.elastic_energy - ea.elastic_energy, 0.5 * k * gap.squaredNorm(), 1e-12);
  const VecX df = eb.force - ea.force;
  EXPECT_LE((df.segment<3>(0) + k * gap).norm(), 1e-9);
  EXPECT_LE((df.segment<3>(24) - k * gap).norm(), 1e-9);
  EXPECT_LE(df.segment(3, 21).norm(), 1e-12);
  EXPECT_THROW(build_cloth_model(m, fabric(), Vec3::Zero(), {}, BendingModel::kHinge, {{0, 9, k}}), InputError);
  EXPECT_THROW(build_cloth_model(cut_grid(5, 5, 2, 0.5, Vec2(1, 0)), fabric(), Vec3::Zero(), {}, BendingModel::kPlate),
               InputError);
}

class Placement : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    pattern_ = new Pattern(load_pattern(std::string(WEFT_SOURCE_DIR) + "/data/patterns/garment_pattern_generator/tee.json"));
    GarmentMeshOptions o;
    o.target_edge_m = 0.03;
    mesh_ = new GarmentMesh(mesh_garment(*pattern_, o));
    body_ = new BindBody(load_bind_body(BodyColliderSpec{}, 1.0));
  }
  static void TearDownTestSuite() {
    delete pattern_;
    delete mesh_;
    delete body_;
  }
  static Pattern* pattern_;
  static GarmentMesh* mesh_;
  static BindBody* body_;
};
Pattern* Placement::pattern_ = nullptr;
GarmentMesh* Placement::mesh_ = nullptr;
BindBody* Placement::body_ = nullptr;

TEST_F(Placement, PanelsAreRolledOnWithoutStretchingAndClearOfTheBody) {
  const PlacedGarment placed = place_garment(*pattern_, *mesh_, *body_);
  EXPECT_EQ(placed.vertices_pushed_out, 0);
  // Rolling onto a cylinder keeps lengths along the axis and around it: every edge keeps its
  // pattern length to within its sag on the curve (edges of 3 cm on radii over 5 cm: < 2%).
  EXPECT_LT(test::largest_edge_stretch(placed), 0.02);
  // The sides: sleeves on the arms (the wearer's left is +x), front and back on the torso,
  // each panel's triangles facing away from the body (outward normals point away from the
  // part's axis, on average).
  for (size_t p = 0; p < pattern_->panels.size(); ++p) {
    const std::string& name = pattern_->panels[p].name;
    const BodyPart want = name[0] == 'l' ? BodyPart::kLeftArm : name[0] == 'r' ? BodyPart::kRightArm : BodyPart::kTorso;
    EXPECT_EQ(placed.panel_part[p], want) << name;
  }
  Vec3 front = Vec3::Zero();
  for (size_t t = 0; t < placed.mesh.triangles.size(); ++t) {
    const auto& tri = placed.mesh.triangles[t];
    const Vec3 a = placed.mesh.positions.row(tri[0]), b = placed.mesh.positions.row(tri[1]), c = placed.mesh.positions.row(tri[2]);
    const Vec3 n = (b - a).cross(c - a);
    const Vec3 centre = (a + b + c) / 3;
    if (pattern_->panels[placed.panel_of_triangle[t]].name == "front") front += n;
    if (pattern_->panels[placed.panel_of_triangle[t]].name == "back") EXPECT_LT(n.z(), 0.5 * n.norm()) << centre.transpose();
  }
  EXPECT_GT(front.z(), 0.9 * front.norm());
  // No triangle meets the body.
  std::vector<double> cloth(3 * placed.mesh.num_vertices()), skin(3 * body_->positions.rows());
  for (int i = 0; i < placed.mesh.num_vertices(); ++i)
    for (int k = 0; k < 3; ++k) cloth[3 * i + k] = placed.mesh.positions(i, k);
  for (Eigen::Index i = 0; i < body_->positions.rows(); ++i)
    for (int k = 0; k < 3; ++k) skin[3 * i + k] = body_->positions(i, k);
  std::vector<std::array<int, 3>> body_triangles(body_->triangles.rows());
  for (Eigen::Index f = 0; f < body_->triangles.rows(); ++f)
    body_triangles[f] = {body_->triangles(f, 0), body_->triangles(f, 1), body_->triangles(f, 2)};
  const AabbTree cloth_tree(placed.mesh.triangles, cloth.data()), body_tree(body_triangles, skin.data());
  EXPECT_EQ(mesh_intersections(cloth.data(), cloth_tree, skin.data(), body_tree).count, 0u);
}

TEST_F(Placement, WeldingMergesEveryStitchIntoOneOrientedMesh) {
  const PlacedGarment placed = place_garment(*pattern_, *mesh_, *body_);
  const SewnGarment welded = weld_seams(placed, placed.mesh.positions);
  // Each stitch's two sides become one row of vertices.
  for (const auto& p : placed.seam_pairs) EXPECT_EQ(welded.welded_vertex[p[0]], welded.welded_vertex[p[1]]);
  std::vector<char> in_seam(placed.mesh.num_vertices(), 0);
  for (const auto& p : placed.seam_pairs) in_seam[p[0]] = in_seam[p[1]] = 1;
  int kept = 0;
  for (int v = 0; v < placed.mesh.num_vertices(); ++v) kept += in_seam[v] ? 0 : 1;
  EXPECT_LT(welded.mesh.num_vertices(), placed.mesh.num_vertices());
  EXPECT_GE(welded.mesh.num_vertices(), kept);
  const EdgeUse before = edge_use(placed.mesh.triangles), after = edge_use(welded.mesh.triangles);
  EXPECT_EQ(after.non_manifold, 0);
  EXPECT_EQ(after.inconsistent, 0);
  EXPECT_LT(after.boundary, before.boundary / 3);  // only the openings stay open
  EXPECT_EQ(welded.mesh.corner_pattern.size(), welded.mesh.triangles.size());
}

TEST_F(Placement, AnOverrideNamingNoPanelIsRefused) {
  PlacementOptions o;
  o.overrides["collar"].part = BodyPart::kHead;
  try {
    place_garment(*pattern_, *mesh_, *body_, o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("placement of panel 'collar': the pattern has no such panel"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace weft
