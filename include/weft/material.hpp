#pragma once
// Fabric materials (docs/method.md section 5): surface density, weft/warp/shear stress-strain
// curves, weft/warp bending rigidity and strain-rate viscosity, all in SI units.
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace weft {

/// Membrane stress (N/m) as a function of Green strain (dimensionless).
/// Either linear (stress = modulus * strain) or a monotone piecewise-cubic (C1) spline through
/// tabulated points, extrapolated linearly past its ends.
///
/// Spline: cubic Hermite segments with Fritsch-Carlson slopes (the three-point weighted harmonic
/// mean of neighbouring secants, zero at local extrema, shape-preserving end slopes), so the
/// curve is monotone wherever the data are and C1 everywhere. Past the first and last knots
/// the curve continues as the straight line with the end slope.
///
/// Energy reference: energy(e) is the exact integral of stress from strain 0 to e of the curve
/// as interpolated and extrapolated, so energy(0) = 0 whether or not 0 is a knot. A table whose
/// extrapolated stress at 0 is not 0 describes a fabric pre-stressed at rest.
class StressCurve {
 public:
  StressCurve() = default;
  static StressCurve linear(double modulus_N_m);
  /// Monotone piecewise-cubic Hermite interpolation (Fritsch-Carlson) through (strain, stress).
  /// strain must be strictly increasing, at least 2 points, all values finite.
  /// Throws InputError "WHERE: ..." otherwise.
  static StressCurve tabulated(std::vector<double> strain, std::vector<double> stress_N_m,
                               const std::string& where = "curve");
  /// Like tabulated(), for a curve known on strain >= 0 only (e.g. shear): the table is
  /// mirrored to stress(-e) = -stress(e). Every strain must be >= 0; if the first is 0 its
  /// stress must be 0, otherwise the point (0, 0) is added.
  static StressCurve odd_symmetric(std::vector<double> strain, std::vector<double> stress_N_m,
                                   const std::string& where = "curve");
  /// The elastic curve between a loading and an unloading branch: both are interpolated
  /// (monotone splines) at the union of their strains inside the strain range they share,
  /// and the two stresses averaged there. The unloading table may list strain in decreasing
  /// order, as recorded. Returns the averaged table (strain, stress), ready for tabulated().
  static std::pair<std::vector<double>, std::vector<double>> average_branches(
      std::vector<double> load_strain, std::vector<double> load_stress,
      std::vector<double> unload_strain, std::vector<double> unload_stress,
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
  const std::vector<double>& slopes() const { return slope_; }  ///< Hermite slope at each knot

 private:
  // Integral of stress from the first knot to e (any e, extrapolated parts included).
  double integral_from_first_knot(double e) const;

  double modulus_ = 0.0;
  std::vector<double> strain_, stress_, slope_;  // spline knots and Hermite slopes
  std::vector<double> energy_at_knot_;           // integral of stress from the first knot
  double energy_offset_ = 0.0;                   // integral from the first knot to strain 0
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

/// True when two materials have the same density, curves, coupling, bending rigidities and
/// viscosity (their names and sources aside): they make the same cloth.
bool same_parameters(const Material& a, const Material& b);

/// A material per triangle of a mesh: triangle t is made of materials[index[t]]; an empty
/// `index` makes every triangle of materials[0] (a garment's panels of different fabrics).
struct TriangleMaterials {
  std::vector<Material> materials;
  std::vector<int> index;  ///< #F, or empty
};

/// Parses a material from JSON (format: docs/materials.md). `where` names the file or scene key
/// in error messages ("WHERE: field weft.strain: ..."). Accepts a preset name as a string, an
/// inline object, or an object with "preset": NAME or "file": PATH (relative to base_dir) whose
/// other keys override the referenced material.
Material parse_material(const nlohmann::json& j, const std::string& where,
                        const std::string& base_dir = ".");
/// Reads a material file; it must carry "weft_material": 1.
Material load_material_file(const std::string& path);
/// A material file's JSON text; `file` names it in messages and relative "file" references
/// are relative to its folder.
Material parse_material_text(std::string_view text, const std::string& file);
/// A preset from data/materials/NAME.json.
Material material_preset(const std::string& name);
/// Names of the shipped presets.
std::vector<std::string> material_preset_names();
/// "measured" when the preset's `source` starts with "Measured" (numbers from a published
/// table of measurements, as the source says), otherwise "estimated". Throws InputError for an
/// unknown name or an unreadable file.
std::string material_preset_kind(const std::string& name);
/// The shipped presets grouped by kind, for --help: "estimated: cotton, denim, ...; measured:
/// luible-denim, ...". Never throws: a preset whose file cannot be read is listed as "unreadable".
std::string material_preset_listing();
/// Folder holding shipped data (env WEFT_DATA_DIR overrides the build-time default).
std::string data_dir();

}  // namespace weft
