#include "weft/material.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "weft/error.hpp"

namespace weft {

StressCurve StressCurve::linear(double modulus_N_m) {
  StressCurve c;
  c.modulus_ = modulus_N_m;
  return c;
}

StressCurve StressCurve::tabulated(std::vector<double>, std::vector<double>, const std::string& where) {
  throw InputError(where + ": tabulated curves are not implemented yet");
}

double StressCurve::stress(double e) const { return modulus_ * e; }
double StressCurve::tangent(double) const { return modulus_; }
double StressCurve::energy(double e) const { return 0.5 * modulus_ * e * e; }

double Material::coupling_modulus() const {
  return poisson_ratio * std::sqrt(weft.tangent(0.0) * warp.tangent(0.0));
}

std::string data_dir() {
  if (const char* env = std::getenv("WEFT_DATA_DIR")) return env;
  return WEFT_DATA_DIR;
}

Material parse_material(const nlohmann::json& j, const std::string& where, const std::string&) {
  if (!j.is_object()) throw InputError(where + ": expected an object");
  Material m;
  if (j.contains("surface_density")) m.surface_density_kg_m2 = j.at("surface_density").get<double>();
  if (j.contains("weft")) m.weft = StressCurve::linear(j.at("weft").get<double>());
  if (j.contains("warp")) m.warp = StressCurve::linear(j.at("warp").get<double>());
  if (j.contains("shear")) m.shear = StressCurve::linear(j.at("shear").get<double>());
  if (j.contains("bending")) {
    m.bending_rigidity_weft_Nm = m.bending_rigidity_warp_Nm = j.at("bending").get<double>();
  }
  if (j.contains("viscosity")) m.viscosity_Ns_m = j.at("viscosity").get<double>();
  return m;
}

Material load_material_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open material file");
  return parse_material(nlohmann::json::parse(in), path);
}

Material material_preset(const std::string& name) {
  return load_material_file(data_dir() + "/materials/" + name + ".json");
}

std::vector<std::string> material_preset_names() { return {}; }

}  // namespace weft
