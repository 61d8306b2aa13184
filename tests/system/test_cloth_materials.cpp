// A cloth of several materials (a garment whose panels are of different fabrics): each
// triangle's lumped mass and membrane take its own material, a hinge across a seam between
// two materials the mean of their bending rigidities, and the forces and their Jacobians
// still match finite differences of the energy. The grain of a panel turns its material
// coordinates, so stretching a panel cut with its warp along x meets the warp's curve.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "weft/garment/garment_mesh.hpp"
#include "weft/garment/placement.hpp"
#include "weft/garment/sewing.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"
#include "sim/simulation_core.hpp"

namespace weft {
namespace {

// Two rectangles, "left" 0.3 x 0.4 m and "right" 0.2 x 0.4 m, sewn along left's right edge
// (edge 1, upwards) and right's left edge (edge 3, downwards).
Pattern two_panels() {
  return parse_pattern(R"({"properties": {"units_in_meter": 100},
    "pattern": {"panels": {
      "left": {"vertices": [[0, 0], [30, 0], [30, 40], [0, 40]],
               "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]},
      "right": {"vertices": [[0, 0], [20, 0], [20, 40], [0, 40]],
                "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]}},
    "stitches": [[{"panel": "left", "edge": 1}, {"panel": "right", "edge": 3}]]}})",
                       "two_panels.json");
}

/// The meshed panels side by side in the z = 0 plane (right moved 0.3 m along x, so that the
/// stitched edges coincide), not yet welded.
PlacedGarment laid_flat(const GarmentMesh& gm) {
  PlacedGarment out;
  int first = 0;
  size_t count = 0;
  for (const GarmentPanelMesh& p : gm.panels) count += p.vertices_m.size();
  out.mesh.positions = Points::Zero(static_cast<Eigen::Index>(count), 3);
  for (size_t p = 0; p < gm.panels.size(); ++p) {
    const GarmentPanelMesh& pm = gm.panels[p];
    const Vec2 offset(p == 0 ? 0.0 : 0.3, 0.0);
    out.panel_first_vertex.push_back(first);
    for (size_t v = 0; v < pm.vertices_m.size(); ++v) {
      const Vec2 x = pm.vertices_m[v] + offset;
      out.mesh.positions.row(first + static_cast<int>(v)) = Vec3(x.x(), x.y(), 0).transpose();
      out.mesh.pattern.push_back(x);
    }
    for (const auto& t : pm.triangles) {
      out.mesh.triangles.push_back({first + t[0], first + t[1], first + t[2]});
      out.panel_of_triangle.push_back(static_cast<int>(p));
    }
    first += static_cast<int>(pm.vertices_m.size());
  }
  out.panel_first_vertex.push_back(first);
  for (const StitchVertexPairs& st : gm.stitches)
    for (const auto& pr : st.pairs)
      out.seam_pairs.push_back({out.panel_first_vertex[st.panel_a] + pr[0], out.panel_first_vertex[st.panel_b] + pr[1]});
  return out;
}

Material linear_fabric(double density, double weft, double warp, double bending) {
  Material m;
  m.surface_density_kg_m2 = density;
  m.weft = StressCurve::linear(weft);
  m.warp = StressCurve::linear(warp);
  m.shear = StressCurve::linear(0.1 * std::min(weft, warp));
  m.poisson_ratio = 0.2;
  m.bending_rigidity_weft_Nm = m.bending_rigidity_warp_Nm = bending;
  m.viscosity_Ns_m = 2e-3;
  return m;
}

double panel_area(const GarmentPanelMesh& p) { return panel_mesh_stats(p).area_m2; }

TEST(ClothMaterials, EachPanelWeighsItsOwnDensityTimesItsArea) {
  GarmentMeshOptions o;
  o.target_edge_m = 0.05;
  const GarmentMesh gm = mesh_garment(two_panels(), o);
  const PlacedGarment flat = laid_flat(gm);
  const Material light = linear_fabric(0.12, 300, 200, 1e-5), heavy = linear_fabric(0.45, 300, 200, 1e-5);
  const TriangleMaterials materials{{light, heavy}, flat.panel_of_triangle};
  const double expected[2] = {0.12 * panel_area(gm.panels[0]), 0.45 * panel_area(gm.panels[1])};

  // Apart, each panel's vertices carry its own mass.
  const ClothModel apart = build_cloth_model(flat.mesh, materials, Vec3::Zero(), {});
  ASSERT_EQ(apart.materials.size(), 2u);
  for (int p = 0; p < 2; ++p) {
    const int first = flat.panel_first_vertex[p], end = flat.panel_first_vertex[p + 1];
    const double mass = apart.mass.segment(first, end - first).sum();
    EXPECT_NEAR(mass, expected[p], 1e-12 * expected[p]) << "panel " << p;
  }
  // Welded into one garment, the whole weighs both.
  const SewnGarment sewn = weld_seams(flat, flat.mesh.positions);
  ASSERT_LT(sewn.mesh.num_vertices(), flat.mesh.num_vertices());
  const ClothModel welded =
      build_cloth_model(sewn.mesh, TriangleMaterials{{light, heavy}, sewn.panel_of_triangle}, Vec3::Zero(), {});
  EXPECT_NEAR(welded.mass.sum(), expected[0] + expected[1], 1e-12 * (expected[0] + expected[1]));
  // A vertex inside a panel has a third of its triangles' areas times that panel's density.
  std::vector<double> area_around(static_cast<size_t>(sewn.mesh.num_vertices()), 0.0);
  std::vector<int> panels_around(static_cast<size_t>(sewn.mesh.num_vertices()), 0);
  for (size_t t = 0; t < sewn.mesh.triangles.size(); ++t)
    for (int k : sewn.mesh.triangles[t]) {
      area_around[static_cast<size_t>(k)] += welded.membranes[t].area;
      panels_around[static_cast<size_t>(k)] |= 1 << sewn.panel_of_triangle[t];
    }
  int checked[2] = {0, 0};
  for (int v = 0; v < sewn.mesh.num_vertices(); ++v) {
    const int bits = panels_around[static_cast<size_t>(v)];
    if (bits == 3) continue;  // on the seam
    const int p = bits == 1 ? 0 : 1;
    const double want = (p == 0 ? 0.12 : 0.45) * area_around[static_cast<size_t>(v)] / 3;
    EXPECT_NEAR(welded.mass[v], want, 1e-12 * want);
    ++checked[p];
  }
  EXPECT_GT(checked[0], 0);
  EXPECT_GT(checked[1], 0);

  // Panels of one fabric make a cloth of one material (the one-material kernels).
  const ClothModel same = build_cloth_model(flat.mesh, TriangleMaterials{{light, light}, flat.panel_of_triangle},
                                            Vec3::Zero(), {});
  EXPECT_EQ(same.materials.size(), 1u);
  EXPECT_TRUE(same.triangle_material.empty());
  // A bad index is refused.
  std::vector<int> bad = flat.panel_of_triangle;
  bad[3] = 2;
  EXPECT_THROW(build_cloth_model(flat.mesh, TriangleMaterials{{light, heavy}, bad}, Vec3::Zero(), {}), InputError);
  // The plate element takes one material.
  EXPECT_THROW(build_cloth_model(flat.mesh, materials, Vec3::Zero(), {}, BendingModel::kPlate), InputError);
}

TEST(ClothMaterials, AHingeAcrossTwoMaterialsTakesTheMeanOfTheirRigidities) {
  GarmentMeshOptions o;
  o.target_edge_m = 0.05;
  const GarmentMesh gm = mesh_garment(two_panels(), o);
  const SewnGarment sewn = [&] {
    const PlacedGarment flat = laid_flat(gm);
    return weld_seams(flat, flat.mesh.positions);
  }();
  const Material soft = linear_fabric(0.2, 300, 200, 2e-5), stiff = linear_fabric(0.2, 300, 200, 7e-5);
  const ClothModel a = build_cloth_model(sewn.mesh, soft, Vec3::Zero(), {});
  const ClothModel b = build_cloth_model(sewn.mesh, stiff, Vec3::Zero(), {});
  const ClothModel mixed =
      build_cloth_model(sewn.mesh, TriangleMaterials{{soft, stiff}, sewn.panel_of_triangle}, Vec3::Zero(), {});
  const std::vector<FlatStencil> stencils = interior_edge_flat_stencils(sewn.mesh);
  ASSERT_EQ(mixed.bending.size(), stencils.size());
  ASSERT_EQ(a.bending.size(), stencils.size());
  int across = 0;
  for (size_t e = 0; e < stencils.size(); ++e) {
    const int pa = sewn.panel_of_triangle[static_cast<size_t>(stencils[e].triangles[0])];
    const int pb = sewn.panel_of_triangle[static_cast<size_t>(stencils[e].triangles[1])];
    const VecX& wa = a.bending[e].weights;
    const VecX& wb = b.bending[e].weights;
    const VecX want = pa != pb ? VecX(0.5 * (wa + wb)) : pa == 0 ? wa : wb;
    across += pa != pb;
    EXPECT_LE((mixed.bending[e].weights - want).cwiseAbs().maxCoeff(), 1e-12 * want.cwiseAbs().maxCoeff()) << e;
  }
  EXPECT_GT(across, 0);
}

std::mt19937 rng(2024);
double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

/// The welded two-panel garment of two materials, stretched (every membrane in tension, so
/// that the semi-definite stiffness is the exact Jacobian) and jiggled.
struct TwoMaterialCloth {
  ClothModel model;
  VecX x;
  std::vector<int> panel_of_triangle;
};
TwoMaterialCloth stretched_two_material_cloth(const Material& left, const Material& right) {
  GarmentMeshOptions o;
  o.target_edge_m = 0.08;
  const GarmentMesh gm = mesh_garment(two_panels(), o);
  const PlacedGarment flat = laid_flat(gm);
  SewnGarment sewn = weld_seams(flat, flat.mesh.positions);
  TwoMaterialCloth c{build_cloth_model(sewn.mesh, TriangleMaterials{{left, right}, sewn.panel_of_triangle},
                                       Vec3(0, -9.81, 0), {}),
                     VecX(), sewn.panel_of_triangle};
  c.x = c.model.initial_positions();
  for (int i = 0; i < c.model.num_vertices(); ++i) {
    node(c.x, i) = Vec3(1.06 * c.x[3 * i], 1.04 * c.x[3 * i + 1], 0.0);
    node(c.x, i) += Vec3(uniform(-1e-3, 1e-3), uniform(-1e-3, 1e-3), uniform(-4e-3, 4e-3));
  }
  return c;
}

void expect_forces_and_stiffness_match_differences(const Material& left, const Material& right) {
  TwoMaterialCloth c = stretched_two_material_cloth(left, right);
  ASSERT_EQ(c.model.materials.size(), 2u);
  ClothSystem system(c.model, DampingSettings{0.0});
  const VecX v = VecX::Zero(c.x.size());
  Evaluation e;
  system.evaluate(c.x, v, true, e);
  const MatX K = e.stiffness.to_dense();
  const double h = 1e-6;
  double force_scale = e.force.cwiseAbs().maxCoeff(), stiffness_scale = K.cwiseAbs().maxCoeff();
  double force_error = 0, stiffness_error = 0;
  for (Eigen::Index k = 0; k < c.x.size(); ++k) {
    VecX xp = c.x, xm = c.x;
    xp[k] += h;
    xm[k] -= h;
    Evaluation ep, em;
    system.evaluate(xp, v, false, ep);
    system.evaluate(xm, v, false, em);
    const double gradient = (ep.elastic_energy + ep.gravity_energy - em.elastic_energy - em.gravity_energy) / (2 * h);
    force_error = std::max(force_error, std::abs(e.force[k] + gradient));
    stiffness_error = std::max(stiffness_error, ((ep.force - em.force) / (2 * h) - K.col(k)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(force_error, 1e-6 * force_scale);
  EXPECT_LT(stiffness_error, 1e-5 * stiffness_scale);
}

TEST(ClothMaterials, ForcesAndStiffnessOfTwoMaterialsMatchFiniteDifferences) {
  expect_forces_and_stiffness_match_differences(linear_fabric(0.15, 400, 150, 3e-5), linear_fabric(0.3, 120, 500, 8e-5));
  Material cotton = material_preset("cotton");
  expect_forces_and_stiffness_match_differences(cotton, linear_fabric(0.3, 120, 500, 8e-5));
}

TEST(ClothMaterials, EachTriangleStretchesByItsOwnMaterialAndTheStepAssemblyAgrees) {
  // Without bending, the elastic energy is the membranes', each by its own material.
  Material left = linear_fabric(0.15, 400, 150, 0), right = linear_fabric(0.3, 120, 500, 0);
  right.weft = StressCurve::tabulated({-0.05, 0.0, 0.03, 0.06}, {-1.0, 0.0, 2.0, 12.0});
  for (const bool nonlinear : {false, true}) {
    SCOPED_TRACE(nonlinear ? "a spline curve" : "linear curves");
    const Material used_right = nonlinear ? right : linear_fabric(0.3, 120, 500, 0);
    TwoMaterialCloth c = stretched_two_material_cloth(left, used_right);
    ClothSystem system(c.model, DampingSettings{0.05});
    VecX v(c.x.size()), w(c.x.size());
    for (Eigen::Index k = 0; k < v.size(); ++k) {
      v[k] = uniform(-0.2, 0.2);
      w[k] = uniform(-0.01, 0.01);
    }
    double expected = 0;
    for (size_t t = 0; t < c.model.membranes.size(); ++t) {
      std::array<Vec3, 3> xe, ve;
      for (int k = 0; k < 3; ++k) {
        xe[k] = node(c.x, c.model.mesh.triangles[t][k]);
        ve[k] = Vec3::Zero();
      }
      MembraneResult r;
      evaluate_membrane(c.model.membranes[t], c.panel_of_triangle[t] == 0 ? left : used_right, Vec3::Zero(), xe, ve,
                        false, true, r);
      expected += r.energy;
    }
    system.begin_step(c.x, v, 0.01);
    Evaluation e;
    system.evaluate(c.x, v, false, e);
    EXPECT_NEAR(e.elastic_energy, expected, 1e-12 * expected);
    // The fused step assembly (four triangles of mixed materials at a time, for linear
    // curves) equals the reference built from each element's Jacobians.
    StepAssembly fused, reference;
    fused.ck = reference.ck = 2.5e-5;
    fused.cd = reference.cd = 5e-3;
    system.assemble_step(c.x, v, w, fused);
    system.System::assemble_step(c.x, v, w, reference);
    EXPECT_LT((fused.force - reference.force).cwiseAbs().maxCoeff(), 1e-12 * reference.force.cwiseAbs().maxCoeff());
    EXPECT_LT((fused.stiffness_times_w - reference.stiffness_times_w).cwiseAbs().maxCoeff(),
              1e-12 * reference.stiffness_times_w.cwiseAbs().maxCoeff());
    EXPECT_NEAR(fused.elastic_energy, reference.elastic_energy, 1e-12 * reference.elastic_energy);
    EXPECT_NEAR(fused.viscous_power, reference.viscous_power, 1e-12 * std::abs(reference.viscous_power));
    const MatX a = fused.matrix.to_dense(), b = reference.matrix.to_dense();
    EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
    EXPECT_EQ(fused.element_data.empty(), nonlinear) << "linear curves take the batched pass";
  }
}

TEST(ClothMaterials, ThePotentialEnergyAloneIsTheEnergyOfAFullEvaluation) {
  // The energy guard and the contacts' energy account ask for the elastic and gravitational
  // energy only; ClothSystem computes them without the forces. Two materials, one of them a
  // spline curve, bending on, the cloth stretched and jiggled.
  Material left = linear_fabric(0.15, 400, 150, 3e-5), right = linear_fabric(0.3, 120, 500, 8e-5);
  right.weft = StressCurve::tabulated({-0.05, 0.0, 0.03, 0.06}, {-1.0, 0.0, 2.0, 12.0});
  TwoMaterialCloth c = stretched_two_material_cloth(left, right);
  ClothSystem system(c.model, DampingSettings{0.05});
  VecX v(c.x.size());
  for (Eigen::Index k = 0; k < v.size(); ++k) v[k] = uniform(-0.2, 0.2);
  system.begin_step(c.x, v, 0.01);
  Evaluation e;
  system.evaluate(c.x, v, false, e);
  double elastic = 0, gravity = 0;
  system.potential_energy(c.x, elastic, gravity);
  ASSERT_GT(e.elastic_energy, 0);
  EXPECT_NEAR(elastic, e.elastic_energy, 1e-13 * e.elastic_energy);
  EXPECT_NEAR(gravity, e.gravity_energy, 1e-13 * std::abs(e.gravity_energy) + 1e-15);
  // The generic version (any system) gives the same.
  double elastic_generic = 0, gravity_generic = 0;
  system.System::potential_energy(c.x, elastic_generic, gravity_generic);
  EXPECT_NEAR(elastic_generic, e.elastic_energy, 1e-13 * e.elastic_energy);
  EXPECT_NEAR(gravity_generic, e.gravity_energy, 1e-13 * std::abs(e.gravity_energy) + 1e-15);
}

TEST(PanelGrain, APanelCutWithItsWarpAlongXStretchesAlongXByTheWarpCurve) {
  // One rectangle, 0.3 m along x and 0.2 m along y, stretched by 4% along the pattern's x.
  const Pattern pattern = parse_pattern(R"({"properties": {"units_in_meter": 100},
    "pattern": {"panels": {"p": {"vertices": [[0, 0], [30, 0], [30, 20], [0, 20]],
      "edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": [2, 3]}, {"endpoints": [3, 0]}]}}}})",
                                        "rectangle.json");
  Material m = linear_fabric(0.2, 100, 100, 0);
  m.poisson_ratio = 0;
  m.weft = StressCurve::linear(80);
  m.warp = StressCurve::tabulated({0.0, 0.02, 0.05}, {0.0, 10.0, 60.0});
  const double stretch = 1.04, strain = 0.5 * (stretch * stretch - 1);
  for (const double grain_deg : {0.0, 90.0, -90.0}) {
    SCOPED_TRACE("grain " + std::to_string(grain_deg) + " deg");
    GarmentMeshOptions o;
    o.target_edge_m = 0.05;
    o.grain_angle_rad["p"] = grain_deg * M_PI / 180;
    const GarmentMesh gm = mesh_garment(pattern, o);
    const GarmentPanelMesh& panel = gm.panels[0];
    TriMesh mesh;
    mesh.pattern = material_coordinates(panel);
    mesh.triangles = panel.triangles;
    mesh.positions = Points::Zero(static_cast<Eigen::Index>(panel.vertices_m.size()), 3);
    for (size_t v = 0; v < panel.vertices_m.size(); ++v)
      mesh.positions.row(static_cast<Eigen::Index>(v)) =
          Vec3(stretch * panel.vertices_m[v].x(), panel.vertices_m[v].y(), 0).transpose();
    const ClothModel model = build_cloth_model(mesh, m, Vec3::Zero(), {});
    ClothSystem system(model, {});
    Evaluation e;
    const VecX x = model.initial_positions();
    system.evaluate(x, VecX::Zero(x.size()), false, e);
    const double area = 0.3 * 0.2;
    // Along x: the weft at grain 0, the warp at +-90 degrees.
    const double want = area * (grain_deg == 0 ? m.weft.energy(strain) : m.warp.energy(strain));
    EXPECT_NEAR(e.elastic_energy, want, 1e-9 * want);
    // The force pulling the right edge out: the stress along x times the height.
    double pull = 0;
    for (int v = 0; v < model.num_vertices(); ++v)
      if (panel.vertices_m[static_cast<size_t>(v)].x() > 0.3 - 1e-9) pull -= e.force[3 * v];
    const double stress = grain_deg == 0 ? m.weft.stress(strain) : m.warp.stress(strain);
    EXPECT_NEAR(pull, stress * stretch * 0.2, 1e-9 * stress);
  }
}

TEST(ClothMaterials, AGarmentScenesPanelsAreMadeOfTheirOwnMaterials) {
  // The shirt at 4 cm, sewn briefly (how well does not matter here, so its open seams are
  // allowed): a sleeve of denim makes the
  // garment heavier than an all-cotton one by the sleeve's area times the difference in density.
  const std::string shirt = std::string(WEFT_SOURCE_DIR) + "/data/patterns/garmentcode/shirt_mean_specification.json";
  const auto scene = [&](const std::string& panels) {
    return R"({"weft_scene": 1, "duration": 0.02, "frame_interval": 0.02,
      "integrator": {"method": "implicit-midpoint", "dt": 0.01},
      "colliders": [{"type": "body", "bind_pose_hold": 0.5}],
      "cloth": {"material": "cotton", "mesh": {"pattern": {"file": ")" +
           shirt + R"(", "edge_length": 0.04, "sewing_time": 0.02, "allow_open_seams": true, "panels": {)" + panels + "}}}}}";
  };
  const Simulation cotton(parse_scene_text(scene(""), "s.json", "."));
  const Simulation mixed(parse_scene_text(scene(R"("left_sleeve_f": {"material": "denim"})"), "s.json", "."));
  EXPECT_EQ(cotton.core().model().materials.size(), 1u);
  ASSERT_EQ(mixed.core().model().materials.size(), 2u);
  ASSERT_EQ(mixed.core().model().mesh.triangles.size(), cotton.core().model().mesh.triangles.size());
  GarmentMeshOptions o;
  o.target_edge_m = 0.04;
  const Pattern pattern = load_pattern(shirt);
  const GarmentMesh gm = mesh_garment(pattern, o);
  double sleeve_area = 0;
  for (const GarmentPanelMesh& p : gm.panels)
    if (p.name == "left_sleeve_f") sleeve_area = panel_area(p);
  ASSERT_GT(sleeve_area, 0);
  const double extra = (material_preset("denim").surface_density_kg_m2 - material_preset("cotton").surface_density_kg_m2) *
                       sleeve_area;
  EXPECT_NEAR(mixed.core().model().mass.sum() - cotton.core().model().mass.sum(), extra, 1e-9 * cotton.core().model().mass.sum());
  EXPECT_GT(std::abs(extra), 1e-3 * cotton.core().model().mass.sum());
}

}  // namespace
}  // namespace weft
