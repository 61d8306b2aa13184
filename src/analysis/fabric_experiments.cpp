#include "weft/fabric_experiments.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/static_equilibrium.hpp"
#include "mesh/mesh.hpp"
#include "system/cloth.hpp"
#include "weft/error.hpp"

namespace weft {

namespace {

constexpr double kGravity = 9.81;  // m/s^2, as the scenes' default gravity

double radians(double deg) { return deg * std::numbers::pi / 180.0; }
double degrees(double rad) { return rad * 180.0 / std::numbers::pi; }

// Second Piola-Kirchhoff stresses (S_xx, S_yy, S_xy) in the loading frame (x along the pattern
// direction (cos t, sin t), y across it) for Green strains (E_xx, E_yy, E_xy) in that frame,
// through the material's curves in the weft/warp frame (docs/method.md 5: e_uv = U.V = 2 E_uv).
Vec3 loading_frame_stress(const Material& m, double angle_rad, double exx, double eyy, double exy) {
  const Vec2 a(std::cos(angle_rad), std::sin(angle_rad)), b(-a.y(), a.x());
  const Mat2 E = exx * a * a.transpose() + eyy * b * b.transpose() +
                 exy * (a * b.transpose() + b * a.transpose());
  const double euu = E(0, 0), evv = E(1, 1), euv = 2 * E(0, 1);
  const double C = m.coupling_modulus();
  Mat2 S;
  S(0, 0) = m.weft.stress(euu) + C * evv;
  S(1, 1) = m.warp.stress(evv) + C * euu;
  S(0, 1) = S(1, 0) = m.shear.stress(euv);
  return Vec3(a.dot(S * a), b.dot(S * b), a.dot(S * b));
}

// Builds a strip: long axis along world x (0..length, or from -behind), width along world y,
// pattern coordinates rotated so the long axis runs at `angle_rad` from the weft.
TriMesh make_strip(double x0, double length, double width, int cells_along, int cells_across,
                   double angle_rad, bool equilateral = false) {
  // Shifted rows give near-equilateral triangles when cells_across is chosen for it.
  TriMesh mesh = make_grid(length, width, cells_along + 1, cells_across + 1,
                           equilateral ? GridPattern::kShiftedRows : GridPattern::kAlternatingDiagonals);
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  for (int i = 0; i < mesh.num_vertices(); ++i) {
    mesh.positions(i, 0) += x0;
    const double x = mesh.positions(i, 0), y = mesh.positions(i, 1);
    mesh.pattern[i] = Vec2(c * x - s * y, s * x + c * y);
  }
  return mesh;
}

Vec3 column_mean(const VecX& x, int column, int nu, int nv) {
  Vec3 sum = Vec3::Zero();
  for (int j = 0; j < nv; ++j) sum += node(x, j * nu + column);
  return sum / nv;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw InputError(what);
}

// Largest |measured - reference| / |reference| over the points, the reference floored at 1% of
// its largest value (the curves start from 0).
double worst_relative_error(const std::vector<TensilePoint>& points, double TensilePoint::*reference) {
  double largest = 0, worst = 0;
  for (const auto& p : points) largest = std::max(largest, std::abs(p.*reference));
  for (const auto& p : points)
    worst = std::max(worst, std::abs(p.measured_stress - p.*reference) / std::max(std::abs(p.*reference), 0.01 * largest));
  return worst;
}

}  // namespace

double tensile_direction_angle(const std::string& direction) {
  if (direction == "weft") return 0.0;
  if (direction == "warp") return 90.0;
  if (direction == "bias") return 45.0;
  throw InputError("direction \"" + direction + "\": expected weft, warp or bias");
}

double uniaxial_response(const Material& material, double angle_deg, double axial_strain) {
  const double t = radians(angle_deg);
  // Newton on the lateral and shear strains so that S_yy = S_xy = 0; the Jacobian by central
  // differences (the curves are C1), steps halved while the residual does not fall.
  Vec2 lateral = Vec2::Zero();
  auto residual = [&](const Vec2& q) {
    const Vec3 s = loading_frame_stress(material, t, axial_strain, q[0], q[1]);
    return Vec2(s[1], s[2]);
  };
  const double scale = std::max({material.weft.modulus(), material.warp.modulus(), 1.0});
  Vec2 r = residual(lateral);
  for (int it = 0; it < 100 && r.norm() > 1e-13 * scale; ++it) {
    Mat2 J;
    const double h = 1e-7;
    for (int k = 0; k < 2; ++k) {
      Vec2 qp = lateral, qm = lateral;
      qp[k] += h;
      qm[k] -= h;
      J.col(k) = (residual(qp) - residual(qm)) / (2 * h);
    }
    const Vec2 step = -J.fullPivLu().solve(r);
    double lambda = 1.0;
    for (int ls = 0; ls < 30; ++ls, lambda *= 0.5) {
      const Vec2 trial = lateral + lambda * step;
      const Vec2 rt = residual(trial);
      if (rt.norm() < r.norm()) {
        lateral = trial;
        r = rt;
        break;
      }
    }
  }
  return loading_frame_stress(material, t, axial_strain, lateral[0], lateral[1])[0];
}

TensileResult run_tensile_test(const Material& material, const std::string& direction,
                               const TensileOptions& o) {
  const double angle_deg = tensile_direction_angle(direction);
  require(o.length_m > 0 && o.width_m > 0 && std::isfinite(o.length_m) && std::isfinite(o.width_m),
          "tensile strip: length and width must be positive");
  require(o.cells_along >= 4 && o.cells_across >= 1, "tensile strip: needs at least 4 cells along and 1 across");
  require(o.increments >= 1, "tensile test: needs at least one increment");
  TensileResult result;
  result.direction = direction;
  result.angle_deg = angle_deg;
  double max_strain = o.max_strain;
  if (!(max_strain > 0)) {
    auto last = [](const StressCurve& c) { return c.is_linear() ? 0.05 : c.strain_points().back(); };
    max_strain = direction == "weft"   ? last(material.weft)
                 : direction == "warp" ? last(material.warp)
                                       : std::min(last(material.weft), last(material.warp));
  }
  require(std::isfinite(max_strain) && max_strain > 0, "tensile test: the largest strain must be positive");
  result.max_strain = max_strain;

  const int nu = o.cells_along + 1, nv = o.cells_across + 1;
  const double t = radians(angle_deg);
  const ClothModel model = build_cloth_model(make_strip(0.0, o.length_m, o.width_m, o.cells_along, o.cells_across, t),
                                             material, Vec3::Zero(), {});
  ClothSystem system(model, DampingSettings{0.0});
  const int n = model.num_vertices();
  // Sliding clamps: both end columns hold their axial coordinate; one vertex of the fixed end
  // also holds y (no rigid translation); the strip stays in its plane (z held).
  std::vector<char> fixed(3 * n, 0);
  for (int j = 0; j < nv; ++j) {
    fixed[3 * (j * nu)] = 1;
    fixed[3 * (j * nu + nu - 1)] = 1;
  }
  fixed[3 * ((nv / 2) * nu) + 1] = 1;
  for (int i = 0; i < n; ++i) fixed[3 * i + 2] = 1;

  VecX x = model.initial_positions(), force;
  StaticSolveOptions so;
  so.force_tolerance_N = o.force_tolerance_N;
  const int g1 = o.cells_along / 4, g2 = o.cells_along - o.cells_along / 4;
  const double gauge0 = o.length_m * (g2 - g1) / o.cells_along;
  double stretch_prev = 1.0;
  for (int k = 1; k <= o.increments; ++k) {
    const double e = max_strain * k / o.increments;
    const double stretch = std::sqrt(1 + 2 * e);
    // Start from the previous equilibrium stretched uniformly to the new clamp position.
    for (int i = 0; i < n; ++i) x[3 * i] *= stretch / stretch_prev;
    stretch_prev = stretch;
    const StaticSolveResult sr = solve_static_equilibrium(system, x, fixed, so, &force);
    TensilePoint p;
    p.converged = sr.converged;
    p.newton_iterations = sr.iterations;
    p.clamp_strain = e;
    Vec3 reaction = Vec3::Zero();
    for (int j = 0; j < nv; ++j) reaction -= node(force, j * nu + nu - 1);
    p.reaction_N = reaction.norm();
    const double gauge_stretch =
        (column_mean(x, g2, nu, nv) - column_mean(x, g1, nu, nv)).norm() / gauge0;
    p.gauge_strain = 0.5 * (gauge_stretch * gauge_stretch - 1);
    // Force per rest width along the stretched fibre is stretch * S_xx (uniaxial S).
    p.measured_stress = p.reaction_N / (o.width_m * gauge_stretch);
    p.expected_stress = uniaxial_response(material, angle_deg, p.gauge_strain);
    p.input_curve_stress = direction == "weft"   ? material.weft.stress(p.gauge_strain)
                           : direction == "warp" ? material.warp.stress(p.gauge_strain)
                                                 : std::numeric_limits<double>::quiet_NaN();
    result.points.push_back(p);
  }
  result.max_relative_error = worst_relative_error(result.points, &TensilePoint::expected_stress);
  result.max_relative_error_input_curve =
      direction == "bias" ? std::numeric_limits<double>::quiet_NaN()
                          : worst_relative_error(result.points, &TensilePoint::input_curve_stress);
  return result;
}

double elastica_chord_angle_deg(double ratio) {
  // Units of the bending length: theta'' = -(r - s) cos(theta), theta(0) = 0, theta'(r) = 0,
  // theta the downward slope angle. Shooting from the free end is well conditioned (from the
  // clamp it is not for long overhangs): with sigma = r - s and phi(sigma) = theta(r - sigma),
  // phi'' = -sigma cos(phi), phi(0) = tip angle, phi'(0) = 0; bisection on the tip angle in
  // (0, 90 degrees) until phi(r) = 0 (a tip angle of 90 degrees keeps phi at 90 degrees, a small
  // one reaches 0 too early). RK4 along sigma; the chord from the tip offset int (cos, sin) phi.
  const double r = ratio;
  const int steps = 800;
  auto shoot = [&](double tip, double& chord) {
    const double h = r / steps;
    double ph = tip, m = 0, x = 0, y = 0;
    auto f = [](double sg, double a, double b) { return std::pair{b, -sg * std::cos(a)}; };
    for (int i = 0; i < steps; ++i) {
      const double sg = i * h;
      const auto k1 = f(sg, ph, m);
      const auto k2 = f(sg + h / 2, ph + h / 2 * k1.first, m + h / 2 * k1.second);
      const auto k3 = f(sg + h / 2, ph + h / 2 * k2.first, m + h / 2 * k2.second);
      const auto k4 = f(sg + h, ph + h * k3.first, m + h * k3.second);
      const double p1 = ph, p2 = ph + h / 2 * k1.first, p3 = ph + h / 2 * k2.first, p4 = ph + h * k3.first;
      x += h / 6 * (std::cos(p1) + 2 * std::cos(p2) + 2 * std::cos(p3) + std::cos(p4));
      y += h / 6 * (std::sin(p1) + 2 * std::sin(p2) + 2 * std::sin(p3) + std::sin(p4));
      ph += h / 6 * (k1.first + 2 * k2.first + 2 * k3.first + k4.first);
      m += h / 6 * (k1.second + 2 * k2.second + 2 * k3.second + k4.second);
      // The physical strip slopes down all along: reaching 0 before the clamp means the tip
      // angle is too small (past that point phi can swing back and cross 0 again).
      if (ph < 0 && i + 1 < steps) return -1.0;
    }
    chord = degrees(std::atan2(y, x));
    return ph;  // theta at the clamp
  };
  double lo = 0, hi = std::numbers::pi / 2, chord = 0;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (shoot(mid, chord) > 0) hi = mid;
    else lo = mid;
  }
  shoot(0.5 * (lo + hi), chord);
  return chord;
}

namespace {

struct CantileverSetup {
  const Material& material;
  double angle_rad;
  const CantileverOptions& o;
};

CantileverPoint cantilever_equilibrium(const CantileverSetup& s, double overhang) {
  const auto& o = s.o;
  const double h = overhang / o.cells_along;
  const int cells = o.cells_along + o.clamp_cells;
  const bool equilateral = o.mesh == "equilateral";
  const int across = equilateral ? std::max(2, static_cast<int>(std::lround(o.width_m / (std::sqrt(3.0) / 2 * h))))
                                 : o.cells_across;
  const int nu = cells + 1, nv = across + 1;
  const ClothModel model = build_cloth_model(
      make_strip(-o.clamp_cells * h, cells * h, o.width_m, cells, across, s.angle_rad, equilateral), s.material,
      Vec3(0, 0, -kGravity), {}, parse_bending_model(o.bending_model, "--bending-model"));
  ClothSystem system(model, DampingSettings{0.0});
  const int n = model.num_vertices();
  // Clamped flat: every vertex at or behind the clamp edge (column clamp_cells) is held.
  std::vector<char> fixed(3 * n, 0);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i <= o.clamp_cells; ++i)
      for (int c = 0; c < 3; ++c) fixed[3 * (j * nu + i) + c] = 1;
  VecX x = model.initial_positions();
  StaticSolveOptions so;
  so.force_tolerance_N = 1e-9 * model.mass.sum() * kGravity;
  CantileverPoint p;
  p.overhang_m = overhang;
  p.converged = true;
  for (int step = 1; step <= o.load_steps; ++step) {
    so.load_factor = static_cast<double>(step) / o.load_steps;
    p.converged = solve_static_equilibrium(system, x, fixed, so).converged && p.converged;
  }
  const Vec3 d = column_mean(x, nu - 1, nu, nv) - column_mean(x, o.clamp_cells, nu, nv);
  p.chord_angle_deg = degrees(std::atan2(-d.z(), d.x()));
  return p;
}

}  // namespace

CantileverResult run_cantilever_test(const Material& material, const std::string& direction,
                                     const CantileverOptions& o) {
  require(direction == "weft" || direction == "warp",
          "cantilever direction \"" + direction + "\": expected weft or warp");
  require(o.width_m > 0 && std::isfinite(o.width_m), "cantilever strip: width must be positive");
  require(o.cells_along >= 4 && o.cells_across >= 1 && o.clamp_cells >= 1,
          "cantilever strip: needs at least 4 cells along, 1 across and 1 clamped");
  require(o.target_angle_deg > 0 && o.target_angle_deg < 80, "cantilever: target angle must be in (0, 80) degrees");
  require(o.sweep_points >= 2 && o.load_steps >= 1, "cantilever: needs 2 sweep points and 1 load step");
  CantileverResult r;
  r.direction = direction;
  r.rigidity_Nm = direction == "weft" ? material.bending_rigidity_weft_Nm : material.bending_rigidity_warp_Nm;
  require(r.rigidity_Nm > 0, "cantilever: the material's " + direction + " bending rigidity must be positive");
  r.weight_N_m2 = material.surface_density_kg_m2 * kGravity;
  r.analytic_bending_length_m = std::cbrt(r.rigidity_Nm / r.weight_N_m2);
  const double c = r.analytic_bending_length_m;
  const CantileverSetup setup{material, radians(tensile_direction_angle(direction)), o};

  auto solve = [&](double overhang) {
    CantileverPoint p = cantilever_equilibrium(setup, overhang);
    p.elastica_angle_deg = elastica_chord_angle_deg(overhang / c);
    r.sweep.push_back(p);
    return p;
  };
  // Sweep 0.8 c .. 3.2 c (the target 41.5 degrees is near 2 c), extended if it misses.
  std::vector<CantileverPoint> sweep;
  for (int k = 0; k < o.sweep_points; ++k)
    sweep.push_back(solve(c * (0.8 + 2.4 * k / (o.sweep_points - 1))));
  while (sweep.back().chord_angle_deg < o.target_angle_deg && sweep.back().overhang_m < 20 * c)
    sweep.push_back(solve(sweep.back().overhang_m * 1.5));
  while (sweep.front().chord_angle_deg > o.target_angle_deg && sweep.front().overhang_m > 0.05 * c)
    sweep.insert(sweep.begin(), solve(sweep.front().overhang_m / 1.5));
  size_t k = 0;
  while (k + 1 < sweep.size() && sweep[k + 1].chord_angle_deg < o.target_angle_deg) ++k;
  if (k + 1 >= sweep.size() || sweep[k].chord_angle_deg > o.target_angle_deg) {
    r.overhang_m = r.bending_length_m = r.relative_error = r.effective_rigidity_ratio =
        std::numeric_limits<double>::quiet_NaN();
  } else {
    // Illinois regula falsi on the chord angle against the overhang.
    double a = sweep[k].overhang_m, fa = sweep[k].chord_angle_deg - o.target_angle_deg;
    double b = sweep[k + 1].overhang_m, fb = sweep[k + 1].chord_angle_deg - o.target_angle_deg;
    double best = std::abs(fa) < std::abs(fb) ? a : b, fbest = std::min(std::abs(fa), std::abs(fb));
    int side = 0;
    for (int it = 0; it < 40 && fbest > o.angle_tolerance_deg; ++it) {
      const double m = (a * fb - b * fa) / (fb - fa);
      const double fm = solve(m).chord_angle_deg - o.target_angle_deg;
      if (std::abs(fm) < fbest) best = m, fbest = std::abs(fm);
      if ((fm < 0) == (fa < 0)) {
        a = m, fa = fm;
        if (side == -1) fb *= 0.5;
        side = -1;
      } else {
        b = m, fb = fm;
        if (side == 1) fa *= 0.5;
        side = 1;
      }
    }
    r.overhang_m = best;
    r.bending_length_m = best / 2;
    r.relative_error = r.bending_length_m / c - 1;
    r.effective_rigidity_ratio = std::pow(r.bending_length_m / c, 3);
  }
  std::sort(r.sweep.begin(), r.sweep.end(),
            [](const CantileverPoint& p, const CantileverPoint& q) { return p.overhang_m < q.overhang_m; });
  return r;
}

}  // namespace weft
