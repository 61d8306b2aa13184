// Fabric materials (weft/material.hpp): what follows from a material's parameters. Reading
// material files and presets is in src/io/material_file.cpp.
#include "weft/material.hpp"

#include <cmath>

namespace weft {

double Material::coupling_modulus() const {
  return poisson_ratio * std::sqrt(weft.tangent(0.0) * warp.tangent(0.0));
}

namespace {
bool same_curve(const StressCurve& a, const StressCurve& b) {
  return a.modulus() == b.modulus() && a.strain_points() == b.strain_points() && a.stress_points() == b.stress_points();
}
}  // namespace

bool same_parameters(const Material& a, const Material& b) {
  return a.surface_density_kg_m2 == b.surface_density_kg_m2 && same_curve(a.weft, b.weft) &&
         same_curve(a.warp, b.warp) && same_curve(a.shear, b.shear) && a.poisson_ratio == b.poisson_ratio &&
         a.bending_rigidity_weft_Nm == b.bending_rigidity_weft_Nm &&
         a.bending_rigidity_warp_Nm == b.bending_rigidity_warp_Nm && a.viscosity_Ns_m == b.viscosity_Ns_m;
}

}  // namespace weft
