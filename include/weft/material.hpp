#pragma once
// Fabric materials (METHOD.md section 5): surface density, weft/warp/shear stress-strain
// curves, weft/warp bending rigidity and strain-rate viscosity, all in SI units.
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace weft {

/// Membrane stress (N/m) as a function of Green strain (dimensionless).
/// Either linear (stress = modulus * strain) or a monotone piecewise-cubic (C1) spline through
/// tabulated points, extrapolated linearly past its ends.
class StressCurve {
 public:
  StressCurve() = default;
  static StressCurve linear(double modulus_N_m);
  /// Monotone piecewise-cubic Hermite interpolation (Fritsch-Carlson) through (strain, stress).
  /// strain must be strictly increasing. Throws InputError naming `where` otherwise.
  static StressCurve tabulated(std::vector<double> strain, std::vector<double> stress_N_m,
                               const std::string& where = "curve");

  double stress(double strain) const;
  /// d stress / d strain (tangent stiffness, N/m).
  double tangent(double strain) const;
  /// Energy density integral of stress from 0 to strain (J/m^2).
  double energy(double strain) const;
  bool is_linear() const { return strain_.empty(); }
  double modulus() const { return modulus_; }  ///< linear modulus, or tangent at 0 for splines
  const std::vector<double>& strain_points() const { return strain_; }
  const std::vector<double>& stress_points() const { return stress_; }

 private:
  double modulus_ = 0.0;
  std::vector<double> strain_, stress_, slope_;  // spline knots and Hermite slopes
  std::vector<double> energy_at_knot_;           // integral of stress from 0 to each knot
};

struct Material {
  std::string name = "custom";
  std::string source;                    ///< where the values come from
  double surface_density_kg_m2 = 0.15;
  StressCurve weft = StressCurve::linear(500.0);   ///< stress along u against e_uu
  StressCurve warp = StressCurve::linear(500.0);   ///< stress along v against e_vv
  StressCurve shear = StressCurve::linear(50.0);   ///< s_uv against e_uv = U.V
  /// Weft-warp coupling: s_uu += C e_vv, s_vv += C e_uu with
  /// C = poisson_ratio * sqrt(weft'(0) warp'(0)).
  double poisson_ratio = 0.0;
  double bending_rigidity_weft_Nm = 1e-5;  ///< rigidity against bending of the weft yarns
  double bending_rigidity_warp_Nm = 1e-5;  ///< rigidity against bending of the warp yarns
  double viscosity_Ns_m = 0.0;             ///< strain-rate viscosity of the membrane

  double coupling_modulus() const;
};

/// Parses a material from JSON. `where` names the file or scene key in error messages.
/// Accepts either an inline object or {"preset": NAME} / {"file": PATH}.
Material parse_material(const nlohmann::json& j, const std::string& where,
                        const std::string& base_dir = ".");
Material load_material_file(const std::string& path);
/// A preset from data/materials/NAME.json.
Material material_preset(const std::string& name);
/// Names of the shipped presets.
std::vector<std::string> material_preset_names();
/// Folder holding shipped data (env WEFT_DATA_DIR overrides the build-time default).
std::string data_dir();

}  // namespace weft
