// Reading fabric materials: the JSON format with units (docs/materials.md), presets from
// data/materials. The Material a file describes is built here and handed to the model.
#include "weft/material.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <tuple>

#include "weft/input_file.hpp"
#include "io/json_util.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// Version of the material file format this code reads ("weft_material": 1).
constexpr int kFormatVersion = 1;
/// Limit on chains of {"file": ...} / {"preset": ...} references (guards against cycles).
constexpr int kMaxReferenceDepth = 8;

// Bounds on material values (docs/materials.md): far beyond any fabric (a 1 mm steel sheet has
// a membrane modulus of 2e8 N/m and a bending rigidity of about 20 N m); a value outside them
// is a mistake in the file.
constexpr double kMaxSurfaceDensity_kg_m2 = 100;
constexpr double kMaxStress_N_m = 1e9;       ///< moduli and tabulated stresses
constexpr double kMaxStrain = 10;            ///< tabulated Green strains
constexpr double kMaxBendingRigidity_Nm = 1e3;
constexpr double kMaxViscosity_Ns_m = 1e6;

using UnitTable = std::map<std::string, double>;  // unit name -> factor to SI

// Conversion factors to SI. 1 gf = 9.80665e-3 N, so gf/cm = 0.980665 N/m and
// gf cm^2/cm = 9.80665e-5 N m (Kawabata KES-F units).
const UnitTable kStressUnits = {
    {"N/m", 1.0}, {"N/cm", 100.0}, {"kN/m", 1000.0}, {"gf/cm", 0.980665}};
const UnitTable kDensityUnits = {{"kg/m2", 1.0},
                                 {"g/m2", 1e-3},
                                 {"mg/cm2", 1e-2},
                                 {"oz/yd2", 28.349523125e-3 / 0.83612736}};
const UnitTable kBendingUnits = {
    {"N m", 1.0}, {"N m2/m", 1.0}, {"uN m", 1e-6}, {"gf cm2/cm", 9.80665e-5}};
const UnitTable kViscosityUnits = {{"N s/m", 1.0}, {"gf s/cm", 0.980665}};

std::string num(double x) {
  std::ostringstream s;
  s.precision(10);
  s << x;
  return s.str();
}

std::string list(const UnitTable& units) {
  std::string out;
  for (const auto& [name, factor] : units) out += (out.empty() ? "\"" : ", \"") + name + "\"";
  return out;
}

/// Builds error messages "WHERE: field FIELD: ...".
struct Ctx {
  std::string where;
  std::string base_dir;
  int depth = 0;

  std::string prefix(const std::string& field) const { return where + ": field " + field; }
  [[noreturn]] void fail(const std::string& field, const std::string& msg) const {
    throw InputError(prefix(field) + ": " + msg);
  }
};

void check_keys(const Ctx& c, const std::string& field, const json& j,
                std::initializer_list<const char*> allowed) {
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; })) {
      std::string names;
      for (const char* a : allowed) names += (names.empty() ? "" : ", ") + std::string(a);
      c.fail(field.empty() ? key : field + "." + key, "unknown key (expected one of: " + names + ")");
    }
  }
}

double number(const Ctx& c, const std::string& field, const json& v) {
  if (!v.is_number()) c.fail(field, std::string("expected a number, got ") + v.type_name());
  const double x = v.get<double>();
  if (!std::isfinite(x)) c.fail(field, "not a finite number");
  return x;
}

/// Refuses `x` outside [lo, hi] (or (lo, hi] when `open_low`), in `unit`.
void check_range(const Ctx& c, const std::string& field, double x, double lo, double hi, bool open_low,
                 const std::string& unit) {
  if ((open_low ? x > lo : x >= lo) && x <= hi) return;
  c.fail(field, "value " + num(x) + " " + unit + " is out of range " + (open_low ? "(" : "[") + num(lo) + ", " +
                    num(hi) + "] " + unit);
}

std::string text(const Ctx& c, const std::string& field, const json& v) {
  if (!v.is_string()) c.fail(field, std::string("expected a string, got ") + v.type_name());
  return v.get<std::string>();
}

double unit_factor(const Ctx& c, const std::string& field, const json& v, const UnitTable& units) {
  const std::string u = text(c, field, v);
  const auto it = units.find(u);
  if (it == units.end()) c.fail(field, "unknown unit \"" + u + "\" (expected one of: " + list(units) + ")");
  return it->second;
}

/// A scalar: a bare number (SI) or {"value": x, "unit": u}.
double quantity(const Ctx& c, const std::string& field, const json& v, const UnitTable& units) {
  if (v.is_number()) return number(c, field, v);
  if (!v.is_object()) {
    c.fail(field, std::string("expected a number (SI) or {\"value\", \"unit\"}, got ") +
                      v.type_name());
  }
  check_keys(c, field, v, {"value", "unit"});
  if (!v.contains("value")) c.fail(field + ".value", "missing");
  const double factor = v.contains("unit") ? unit_factor(c, field + ".unit", v["unit"], units) : 1.0;
  return number(c, field + ".value", v["value"]) * factor;
}

std::vector<double> column(const Ctx& c, const std::string& field, const json& v) {
  if (!v.is_array()) c.fail(field, std::string("expected an array of numbers, got ") + v.type_name());
  if (v.empty()) c.fail(field, "the table is empty");
  std::vector<double> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    out.push_back(number(c, field + "[" + std::to_string(i) + "]", v[i]));
  }
  return out;
}

/// How the strain column of a table is written and converted to Green strain.
struct StrainConvention {
  double scale = 1.0;        // "1" or "%"
  bool degrees = false;      // shear angle in degrees: e_uv = sin(angle)
  bool engineering = false;  // engineering strain and force per original width
};

/// Reads one (strain, stress) branch and converts it to Green strain and its work-conjugate
/// stress in N/m.
std::pair<std::vector<double>, std::vector<double>> branch(const Ctx& c, const std::string& field,
                                                           const json& v, double stress_factor,
                                                           const StrainConvention& sc,
                                                           bool allow_unload) {
  if (allow_unload) {
    check_keys(c, field, v, {"strain", "stress", "unit", "strain_unit", "strain_measure", "unload"});
  } else {
    check_keys(c, field, v, {"strain", "stress", "unit"});
  }
  if (!v.contains("strain")) c.fail(field + ".strain", "missing");
  if (!v.contains("stress")) c.fail(field + ".stress", "missing");
  if (v.contains("unit")) stress_factor = unit_factor(c, field + ".unit", v["unit"], kStressUnits);
  std::vector<double> x = column(c, field + ".strain", v["strain"]);
  std::vector<double> y = column(c, field + ".stress", v["stress"]);
  if (x.size() != y.size()) {
    c.fail(field, "strain has " + std::to_string(x.size()) + " points but stress has " +
                      std::to_string(y.size()));
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    double e = x[i] * sc.scale;
    double s = y[i] * stress_factor;
    if (sc.degrees) {
      if (std::abs(x[i]) >= 90.0) {
        c.fail(field + ".strain", "shear angle " + num(x[i]) + " deg is not within (-90, 90)");
      }
      e = std::sin(x[i] * std::numbers::pi / 180.0);
    }
    if (sc.engineering) {
      // Green strain e = eps + eps^2/2; the measured force per original width T pairs with eps,
      // the model stress s = dW/de = T / (1 + eps) pairs with e.
      if (e <= -1.0) c.fail(field + ".strain", "engineering strain " + num(e) + " is <= -1");
      s /= 1.0 + e;
      e += 0.5 * e * e;
    }
    check_range(c, field + ".strain[" + std::to_string(i) + "]", e, -kMaxStrain, kMaxStrain, false, "(Green strain)");
    check_range(c, field + ".stress[" + std::to_string(i) + "]", s, -kMaxStress_N_m, kMaxStress_N_m, false, "N/m");
    x[i] = e;
    y[i] = s;
  }
  return {std::move(x), std::move(y)};
}

/// Strain over which a softened compression blends into the tensile modulus, each side of 0.
constexpr double kCompressionBlendStrain = 1e-4;

/// A linear curve of modulus k in tension and f k in compression (0 < f <= 1): the spline
/// through (-2d, -2fkd), (-d, -fkd), (0, 0), (d, kd), (2d, 2kd) with d the blend strain is the
/// straight line f k e for e <= -d and k e for e >= d (the Fritsch-Carlson slopes there are the
/// secants, and so are the end slopes it is extended with), with a monotone C1 blend between.
StressCurve compression_softened(double k, double f, const std::string& where) {
  if (f == 1.0) return StressCurve::linear(k);
  const double d = kCompressionBlendStrain;
  return StressCurve::tabulated({-2 * d, -d, 0.0, d, 2 * d}, {-2 * d * f * k, -d * f * k, 0.0, d * k, 2 * d * k},
                                where);
}

StressCurve curve(const Ctx& c, const std::string& field, const json& v, bool shear) {
  if (v.is_number()) {
    const double k = number(c, field, v);
    if (!(k > 0.0)) c.fail(field, "linear modulus must be positive, got " + num(k));
    check_range(c, field, k, 0, kMaxStress_N_m, true, "N/m");
    return StressCurve::linear(k);
  }
  if (!v.is_object()) {
    c.fail(field, std::string("expected a number (N/m), {\"linear\": ...} or a table, got ") +
                      v.type_name());
  }
  if (v.contains("linear")) {
    check_keys(c, field, v, {"linear", "unit", "compression"});
    const double factor =
        v.contains("unit") ? unit_factor(c, field + ".unit", v["unit"], kStressUnits) : 1.0;
    const double k = number(c, field + ".linear", v["linear"]) * factor;
    if (!(k > 0.0)) c.fail(field + ".linear", "modulus must be positive, got " + num(k));
    check_range(c, field + ".linear", k, 0, kMaxStress_N_m, true, "N/m");
    if (!v.contains("compression")) return StressCurve::linear(k);
    // Woven fabric buckles at a small fraction of its tensile stiffness (docs/materials.md).
    if (shear) c.fail(field + ".compression", "applies to weft and warp only (shear is symmetric)");
    const double f = number(c, field + ".compression", v["compression"]);
    check_range(c, field + ".compression", f, 0, 1, true, "(fraction of the tensile modulus)");
    return compression_softened(k, f, c.prefix(field));
  }
  check_keys(c, field, v, {"strain", "stress", "unit", "strain_unit", "strain_measure", "unload"});
  const double factor =
      v.contains("unit") ? unit_factor(c, field + ".unit", v["unit"], kStressUnits) : 1.0;
  StrainConvention sc;
  if (v.contains("strain_unit")) {
    const std::string u = text(c, field + ".strain_unit", v["strain_unit"]);
    if (u == "%") {
      sc.scale = 0.01;
    } else if (u == "deg" && shear) {
      sc.degrees = true;
    } else if (u != "1") {
      c.fail(field + ".strain_unit", "unknown unit \"" + u + "\" (expected one of: \"1\", \"%\"" +
                                         (shear ? ", \"deg\")" : ")"));
    }
  }
  if (v.contains("strain_measure")) {
    const std::string m = text(c, field + ".strain_measure", v["strain_measure"]);
    if (m == "engineering" && !shear) {
      sc.engineering = true;
    } else if (m != "green") {
      c.fail(field + ".strain_measure", "unknown strain measure \"" + m + "\" (expected \"green\"" +
                                            (shear ? ")" : " or \"engineering\")"));
    }
  }
  auto [x, y] = branch(c, field, v, factor, sc, true);
  if (v.contains("unload")) {
    auto [ux, uy] = branch(c, field + ".unload", v["unload"], factor, sc, false);
    std::tie(x, y) = StressCurve::average_branches(std::move(x), std::move(y), std::move(ux),
                                                   std::move(uy), c.prefix(field));
  }
  // A falling stress-strain curve has a negative tangent stiffness: unstable and unphysical.
  for (std::size_t i = 1; i < y.size(); ++i) {
    if (y[i] < y[i - 1] && x[i] > x[i - 1]) {
      c.fail(field + ".stress", "must not decrease with strain, but stress " + num(y[i - 1]) +
                                    " N/m at strain " + num(x[i - 1]) + " is followed by " +
                                    num(y[i]) + " N/m at strain " + num(x[i]));
    }
  }
  // Shear tables on strain >= 0 are mirrored (odd symmetry); tables reaching negative strain
  // are used as given.
  if (shear && !x.empty() && x.front() >= 0.0) {
    return StressCurve::odd_symmetric(std::move(x), std::move(y), c.prefix(field));
  }
  return StressCurve::tabulated(std::move(x), std::move(y), c.prefix(field));
}

std::vector<std::string> preset_names_in(const std::string& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.is_regular_file() && entry.path().extension() == ".json") {
      names.push_back(entry.path().stem().string());
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// Path of a shipped preset; throws "PREFIX: unknown material preset ..." if there is none.
std::string preset_path(const std::string& name, const std::string& prefix) {
  const std::vector<std::string> names = material_preset_names();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string available;
    for (const auto& n : names) available += (available.empty() ? "" : ", ") + n;
    throw InputError(prefix + "unknown material preset \"" + name + "\" (available: " +
                     (available.empty() ? "none found in " + data_dir() + "/materials" : available) +
                     ")");
  }
  return data_dir() + "/materials/" + name + ".json";
}

Material load_file(const std::string& path, int depth);

void parse_into(Material& m, const json& j, const Ctx& c) {
  if (j.is_string()) {
    m = load_file(preset_path(j.get<std::string>(), c.where + ": "), c.depth + 1);
    return;
  }
  if (!j.is_object()) {
    throw InputError(c.where + ": expected a material object or a preset name, got " +
                     j.type_name());
  }
  check_keys(c, "", j,
             {"weft_material", "name", "source", "notes", "preset", "file", "surface_density",
              "weft", "warp", "shear", "poisson_ratio", "bending_rigidity", "viscosity"});
  if (j.contains("weft_material")) {
    const json& v = j["weft_material"];
    if (!v.is_number_integer() || v.get<long long>() != kFormatVersion) {
      c.fail("weft_material", "unsupported format version " + v.dump() + " (this weft reads " +
                                  std::to_string(kFormatVersion) + ")");
    }
  }
  if (j.contains("preset") && j.contains("file")) {
    c.fail("preset", "give either \"preset\" or \"file\", not both");
  }
  if (c.depth > kMaxReferenceDepth) {
    throw InputError(c.where + ": material references nested deeper than " +
                     std::to_string(kMaxReferenceDepth) + " (a cycle?)");
  }
  if (j.contains("preset")) {
    const std::string name = text(c, "preset", j["preset"]);
    m = load_file(preset_path(name, c.prefix("preset") + ": "), c.depth + 1);
  }
  if (j.contains("file")) {
    fs::path p = text(c, "file", j["file"]);
    if (p.is_relative()) p = fs::path(c.base_dir) / p;
    m = load_file(p.string(), c.depth + 1);
  }
  if (j.contains("name")) m.name = text(c, "name", j["name"]);
  if (j.contains("source")) m.source = text(c, "source", j["source"]);
  if (j.contains("notes")) text(c, "notes", j["notes"]);
  if (j.contains("surface_density")) {
    const double rho = quantity(c, "surface_density", j["surface_density"], kDensityUnits);
    if (!(rho > 0.0)) c.fail("surface_density", "must be positive, got " + num(rho) + " kg/m2");
    check_range(c, "surface_density", rho, 0, kMaxSurfaceDensity_kg_m2, true, "kg/m2");
    m.surface_density_kg_m2 = rho;
  }
  if (j.contains("weft")) m.weft = curve(c, "weft", j["weft"], false);
  if (j.contains("warp")) m.warp = curve(c, "warp", j["warp"], false);
  if (j.contains("shear")) m.shear = curve(c, "shear", j["shear"], true);
  if (j.contains("poisson_ratio")) {
    const double nu = number(c, "poisson_ratio", j["poisson_ratio"]);
    // |nu| < 1 keeps the coupled weft-warp stiffness positive definite.
    if (!(std::abs(nu) < 1.0)) c.fail("poisson_ratio", "must be within (-1, 1), got " + num(nu));
    m.poisson_ratio = nu;
  }
  if (j.contains("bending_rigidity")) {
    const json& v = j["bending_rigidity"];
    const std::string f = "bending_rigidity";
    double weft = 0.0, warp = 0.0;
    if (v.is_number()) {
      weft = warp = number(c, f, v);
    } else if (v.is_object()) {
      check_keys(c, f, v, {"weft", "warp", "value", "unit"});
      const double factor =
          v.contains("unit") ? unit_factor(c, f + ".unit", v["unit"], kBendingUnits) : 1.0;
      if (v.contains("value")) {
        if (v.contains("weft") || v.contains("warp")) {
          c.fail(f + ".value", "give either \"value\" or \"weft\" and \"warp\", not both");
        }
        weft = warp = number(c, f + ".value", v["value"]) * factor;
      } else {
        if (!v.contains("weft")) c.fail(f + ".weft", "missing");
        if (!v.contains("warp")) c.fail(f + ".warp", "missing");
        weft = number(c, f + ".weft", v["weft"]) * factor;
        warp = number(c, f + ".warp", v["warp"]) * factor;
      }
    } else {
      c.fail(f, std::string("expected a number (N m) or {\"weft\", \"warp\", \"unit\"}, got ") +
                    v.type_name());
    }
    if (weft < 0.0) c.fail(f + ".weft", "must not be negative, got " + num(weft) + " N m");
    if (warp < 0.0) c.fail(f + ".warp", "must not be negative, got " + num(warp) + " N m");
    check_range(c, f + ".weft", weft, 0, kMaxBendingRigidity_Nm, false, "N m");
    check_range(c, f + ".warp", warp, 0, kMaxBendingRigidity_Nm, false, "N m");
    m.bending_rigidity_weft_Nm = weft;
    m.bending_rigidity_warp_Nm = warp;
  }
  if (j.contains("viscosity")) {
    const double eta = quantity(c, "viscosity", j["viscosity"], kViscosityUnits);
    if (eta < 0.0) c.fail("viscosity", "must not be negative, got " + num(eta) + " N s/m");
    check_range(c, "viscosity", eta, 0, kMaxViscosity_Ns_m, false, "N s/m");
    m.viscosity_Ns_m = eta;
  }
}

Material parse_text(std::string_view text, const std::string& path, int depth) {
  const json j = json_util::parse_json(text, path);
  Ctx c{path, fs::path(path).parent_path().string(), depth};
  if (c.base_dir.empty()) c.base_dir = ".";
  if (!j.is_object()) throw InputError(path + ": expected a JSON object");
  if (!j.contains("weft_material")) {
    c.fail("weft_material", "missing (a material file starts with \"weft_material\": " +
                                std::to_string(kFormatVersion) + ")");
  }
  // A file says where its numbers come from (docs/materials.md): a measured preset cites its
  // table, an estimate says so, a variant of another file says what it changed.
  if (!j.contains("source")) {
    c.fail("source", "missing (a material file says where its numbers come from: the publication, "
                     "table and sample of measured values, or that they are estimated)");
  }
  const std::string source = weft::text(c, "source", j["source"]);
  if (source.find_first_not_of(" \t\r\n") == std::string::npos) {
    c.fail("source", "empty (a material file says where its numbers come from: the publication, "
                     "table and sample of measured values, or that they are estimated)");
  }
  Material m;
  parse_into(m, j, c);
  return m;
}

Material load_file(const std::string& path, int depth) {
  return parse_text(read_input_file(path, "material file"), path, depth);
}

}  // namespace

std::string data_dir() {
  if (const char* env = std::getenv("WEFT_DATA_DIR")) return env;
  return WEFT_DATA_DIR;
}

Material parse_material(const nlohmann::json& j, const std::string& where,
                        const std::string& base_dir) {
  Material m;
  parse_into(m, j, Ctx{where, base_dir, 0});
  return m;
}

Material load_material_file(const std::string& path) { return load_file(path, 0); }

Material parse_material_text(std::string_view text, const std::string& file) { return parse_text(text, file, 0); }

Material material_preset(const std::string& name) { return load_file(preset_path(name, ""), 0); }

std::vector<std::string> material_preset_names() {
  return preset_names_in(data_dir() + "/materials");
}

namespace {
/// "measured" when the material file's `source` starts with "Measured", else "estimated".
std::string kind_of_file(const std::string& path) {
  const json j = json_util::parse_json(read_input_file(path, "material file"), path);
  const Ctx c{path, ".", 0};
  const std::string source = j.is_object() && j.contains("source") ? text(c, "source", j["source"]) : "";
  return source.rfind("Measured", 0) == 0 ? "measured" : "estimated";
}
}  // namespace

std::string material_preset_kind(const std::string& name) { return kind_of_file(preset_path(name, "")); }

std::string material_preset_listing() {
  std::map<std::string, std::string> groups;  // kind -> "a, b, ..."
  for (const std::string& name : material_preset_names()) {
    std::string kind;
    try {
      kind = kind_of_file(data_dir() + "/materials/" + name + ".json");
    } catch (const std::exception&) {
      kind = "unreadable";
    }
    std::string& names = groups[kind];
    names += (names.empty() ? "" : ", ") + name;
  }
  std::string out;
  for (const char* kind : {"estimated", "measured", "unreadable"}) {
    if (groups.count(kind)) out += (out.empty() ? "" : "; ") + std::string(kind) + ": " + groups[kind];
  }
  return out;
}

}  // namespace weft
