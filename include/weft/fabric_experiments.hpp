#pragma once
// Validation experiments of the fabric model (docs/method.md 5, docs/fabric-validation.md):
// a quasi-static tensile test along weft, warp and bias, and the cantilever bending test
// (ASTM D1388). Both solve static equilibria of the full cloth system (membrane triangles,
// bending stencils, gravity), so they check the assembled model against its input data.
#include <string>
#include <vector>

#include "weft/material.hpp"

namespace weft {

// ---------------------------------------------------------------- tensile test

/// Uniaxial response of the membrane model (docs/method.md 5) of one homogeneous element loaded
/// along the pattern direction at `angle_deg` from the weft (0 = weft, 90 = warp, 45 = bias):
/// the lateral strain and the in-plane shear strain are solved so that the lateral and shear
/// stresses vanish (free long edges). Returns the axial stress S_xx (N/m, second
/// Piola-Kirchhoff: the measure of the material curves) at axial Green strain `axial_strain`.
/// With no Poisson coupling, weft and warp give exactly the input curves.
double uniaxial_response(const Material& material, double angle_deg, double axial_strain);

struct TensileOptions {
  double length_m = 0.2;
  double width_m = 0.05;
  int cells_along = 40;
  int cells_across = 10;
  int increments = 16;
  /// Largest axial Green strain; <= 0: the last point of the curve along the direction (for
  /// the bias, the smaller of the weft and warp ones).
  double max_strain = 0;
  double force_tolerance_N = 1e-9;
};

struct TensilePoint {
  double clamp_strain = 0;     ///< Green strain of the clamp separation
  double gauge_strain = 0;     ///< Green strain of the middle half of the strip (extensometer)
  double reaction_N = 0;       ///< |force| the moving clamp exerts on the strip
  double measured_stress = 0;  ///< reaction / (width * gauge stretch), N/m (S_xx)
  double expected_stress = 0;  ///< uniaxial_response at the gauge strain, N/m
  double input_curve_stress = 0;  ///< weft or warp curve at the gauge strain (NaN for bias)
  int newton_iterations = 0;
  bool converged = false;
};

struct TensileResult {
  std::string direction;  ///< "weft", "warp" or "bias"
  double angle_deg = 0;
  std::vector<TensilePoint> points;
  /// Largest |measured - expected| / max(|expected|, 1% of the largest expected stress).
  double max_relative_error = 0;
  /// The same against the input curve (weft and warp; NaN for the bias). Differs from
  /// max_relative_error by the lateral contraction that Poisson coupling allows.
  double max_relative_error_input_curve = 0;
  double max_strain = 0;
};

/// A strip of `options.length_m` by `options.width_m` whose long axis runs at `angle_deg`
/// from the weft in the pattern, held by sliding clamps (axial coordinate held, the other
/// in-plane one free) at both ends and stretched in increments, each a static equilibrium.
/// The whole strip is kept in its plane. Throws InputError for bad options.
TensileResult run_tensile_test(const Material& material, const std::string& direction,
                               const TensileOptions& options);

/// Pattern angle (degrees from the weft) of "weft", "warp" or "bias"; throws InputError.
double tensile_direction_angle(const std::string& direction);

// ---------------------------------------------------------------- cantilever test

/// Chord angle (degrees below horizontal, from the clamp edge to the tip) of the inextensible
/// elastica of a cantilever under its own weight with overhang / bending length `ratio`
/// (shooting on the exact large-deflection equation B theta'' = -w g (L - s) cos theta).
double elastica_chord_angle_deg(double ratio);

struct CantileverOptions {
  double width_m = 0.025;
  int cells_along = 20;   ///< cells along the overhang
  int cells_across = 6;
  int clamp_cells = 1;    ///< cells held flat behind the clamp edge (two rows or more of pins)
  double target_angle_deg = 41.5;
  int sweep_points = 8;   ///< overhangs from 0.8 to 3.2 bending lengths, for the plot
  double angle_tolerance_deg = 0.01;
  int load_steps = 4;     ///< gravity ramp of each equilibrium from the flat strip
  std::string bending_model = "hinge";  ///< "hinge" (docs/method.md 5) or "plate"
  /// "equilateral": near-equilateral triangles (rows shifted by half a cell; cells_across
  /// follows from the width), like a garment mesh; "grid": make_grid's squares split along
  /// alternating diagonals, cells_across rows.
  std::string mesh = "equilateral";
};

struct CantileverPoint {
  double overhang_m = 0;
  double chord_angle_deg = 0;
  double elastica_angle_deg = 0;  ///< exact elastica at the same overhang and analytic c
  bool converged = false;
};

struct CantileverResult {
  std::string direction;       ///< "weft" or "warp": the strip's long axis
  double rigidity_Nm = 0;      ///< B of the yarns along the strip
  double weight_N_m2 = 0;      ///< w g
  double analytic_bending_length_m = 0;  ///< (B / (w g))^(1/3)
  double overhang_m = 0;                 ///< overhang at the target chord angle
  double bending_length_m = 0;           ///< overhang / 2 (ASTM D1388)
  double relative_error = 0;             ///< bending_length / analytic - 1
  /// Rigidity the strip behaves with, B (bending_length / analytic)^3, over B.
  double effective_rigidity_ratio = 0;
  std::vector<CantileverPoint> sweep;    ///< every equilibrium computed, by overhang
};

/// A strip whose long axis is the weft or the warp, flat and held over `clamp_cells` cells
/// behind the clamp edge, overhanging by L under gravity; finds L where the chord angle is the
/// target (sweep, then regula falsi between the bracketing overhangs). Throws InputError.
CantileverResult run_cantilever_test(const Material& material, const std::string& direction,
                                     const CantileverOptions& options);

}  // namespace weft
