// Adaptive damping in a cloth of several materials (docs/method.md 4): each triangle's
// viscosity is raised to exactly the target ratio of its own material's stiffness (or left at
// its own material's viscosity where that is more), whichever material the cloth's first
// triangle is made of, for linear and for tabulated curves.
#include <gtest/gtest.h>

#include <cmath>

#include "damping/adaptive.hpp"
#include "elements/membrane.hpp"
#include "weft/experiments/stability_experiment.hpp"
#include "sim/simulation_core.hpp"

using namespace weft;

namespace {

// A material whose weft curve is linear or tabulated (stiffening), `scale` times as stiff as
// the softest, with the density and viscosity given.
Material fabric(double scale, double density, double viscosity, double poisson, bool tabulated) {
  Material m;
  m.surface_density_kg_m2 = density;
  m.weft = tabulated ? StressCurve::tabulated({0, 0.02, 0.05, 0.1}, {0, 2 * scale, 8 * scale, 40 * scale})
                     : StressCurve::linear(100 * scale);
  m.warp = StressCurve::linear(120 * scale);
  m.shear = StressCurve::linear(10 * scale);
  m.poisson_ratio = poisson;
  m.viscosity_Ns_m = viscosity;
  return m;
}

Material soft(bool tabulated) { return fabric(1, 0.1, 0.002, 0.0, tabulated); }
Material stiff(bool tabulated) { return fabric(40, 0.3, 0.0, 0.2, tabulated); }

}  // namespace

TEST(AdaptiveDampingMaterials, EachTriangleIsDampedByItsOwnMaterial) {
  const double zeta = 0.1, dt = 0.01;
  for (bool tabulated : {false, true}) {
    for (bool soft_first : {true, false}) {
      SCOPED_TRACE(testing::Message() << (tabulated ? "tabulated" : "linear") << (soft_first ? ", soft first" : ", stiff first"));
      StabilityExperimentSettings s;
      s.size_m = 0.3;
      s.resolution = 7;
      Scene scene = stability_scene(s, {"Implicit Midpoint", "implicit-midpoint", std::nullopt}, dt, zeta);
      scene.cloth.self_collision = false;
      const TriMesh mesh = build_cloth_mesh(scene.cloth);
      // The triangles left of the middle of one material, the others of the second.
      std::vector<int> index(mesh.triangles.size());
      double mid = 0;
      for (int i = 0; i < mesh.num_vertices(); ++i) mid += mesh.pattern[i].x() / mesh.num_vertices();
      for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        double u = 0;
        for (int k : mesh.triangles[t]) u += mesh.pattern[k].x() / 3;
        index[t] = u < mid ? 0 : 1;
      }
      ASSERT_EQ(index[0], 0);
      scene.cloth.triangle_materials = {soft_first ? std::vector<Material>{soft(tabulated), stiff(tabulated)}
                                                   : std::vector<Material>{stiff(tabulated), soft(tabulated)},
                                        index};
      Simulation sim(scene);
      const ClothModel& model = sim.core().model();
      ASSERT_EQ(model.materials.size(), 2u);
      VecX x, v;
      stability_perturbation(s, model.mesh, model.mass, x, v);
      sim.core().system().begin_step(x, v, dt);
      const auto& viscosity = sim.core().system().membrane_viscosity();
      int raised = 0;
      for (size_t t = 0; t < model.membranes.size(); ++t) {
        const Material& own = scene.cloth.triangle_materials.materials[index[t]];
        ASSERT_TRUE(same_parameters(model.material_of(t), own)) << "triangle " << t;
        const auto& g = model.membranes[t];
        std::array<Vec3, 3> xe, ve;
        for (int k = 0; k < 3; ++k) {
          xe[k] = node(x, model.mesh.triangles[t][k]);
          ve[k].setZero();
        }
        MembraneResult r;
        evaluate_membrane(g, own, viscosity[t], xe, ve, false, true, r);
        // A linear material's moduli are the same at every strain (the step reads them at 0).
        const Vec3 E = membrane_tangent_moduli(own, tabulated ? r.strain : Vec3::Zero());
        const Vec3& S = model.membrane_mass_sums[t];
        const Vec3 kappa = membrane_kappa(g.area, E, S, dt);
        const Vec3 lambda = membrane_lambda(g.area, viscosity[t], S, dt);
        const Vec3 own_lambda = membrane_lambda(g.area, Vec3::Constant(own.viscosity_Ns_m), S, dt);
        for (int k = 0; k < 3; ++k) {
          const double target = 2 * zeta * std::sqrt(std::max(kappa[k], 0.0));
          EXPECT_NEAR(lambda[k], std::max(target, own_lambda[k]), 1e-9 * lambda[k])
              << "triangle " << t << " (material " << index[t] << ") mode " << k;
          if (target > own_lambda[k]) ++raised;
        }
      }
      EXPECT_GT(raised, 0);
    }
  }
}
