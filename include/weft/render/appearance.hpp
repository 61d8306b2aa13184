#pragma once
// The look of weft's pictures, shared by `weft render` and the viewer's page (docs/render.md,
// "One look"): the colour maps, the surfaces' colours and the shading's constants come from
// src/render/appearance.json, which the build compiles in here and bundles into the page
// (viewer/src/appearance.js), and the strain field and its scale are computed the same way on
// both sides (viewer/src/strain.js). tests/render/test_appearance.cpp checks the two against
// each other.
#include <array>
#include <string>
#include <vector>

#include "weft/render/raster.hpp"

namespace weft::render {

/// The text of src/render/appearance.json as it was built in.
const std::string& appearance_json();

/// The shading's constants (appearance.json "shading").
struct Shading {
  double ambient = 0, ambient_up = 0, key = 0, headlight = 0;
  double key_right = 0, key_up = 0, key_back = 0;  ///< the key light's direction, before normalising
  double key_min_elevation = 0;
  double cloth_highlight = 0, cloth_shininess = 1, collider_highlight = 0, collider_shininess = 1;
  double coloured_back_factor = 1;     ///< a colour map's colour on the cloth's back side is multiplied by this
  double collider_crease_cosine = 0;  ///< a collider's vertex normal further than this (cosine) from its face's gives way to the face's
};
const Shading& shading();

/// The surfaces' own colours, linear RGB.
Colour cloth_colour();
Colour cloth_back_colour();
Colour collider_colour();

/// Linear RGB of sRGB bytes.
Colour from_srgb(int r, int g, int b);

/// Colour maps, linear RGB: `fraction` in [0, 1] along the sequential ramp (added viscosity);
/// `signed_fraction` in [-1, 1] along the diverging ramp, its middle stop at 0 (strain). Values
/// outside are clamped; NaN gives the ramp's middle (sequential: its start).
Colour sequential_colour(double fraction);
Colour diverging_colour(double signed_fraction);

/// The largest principal stretch of a triangle whose corners are at x0, x1, x2 and whose rest
/// shape has the 2D pattern coordinates u0, u1, u2: the largest singular value of the
/// deformation gradient F = [x1 - x0, x2 - x0] [u1 - u0, u2 - u0]^-1 (1 for a triangle at rest,
/// also when it is rotated). NaN when the pattern triangle has no area.
double largest_principal_stretch(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec2& u0, const Vec2& u1,
                                 const Vec2& u2);

/// The strain the colour map shows, per vertex: the mean over the vertex's triangles of
/// (largest principal stretch - 1), weighted by the triangles' areas in texture space, with
/// the texture coordinates times `uv_scale` as the pattern. `xyz`: 3 per vertex;
/// `corner_texcoords`: (u, v) of each triangle's corners, 6 per triangle. Triangles of
/// texture-space area 1e-14 or less are left out; a vertex with none gets 0.
std::vector<double> vertex_strain(const std::vector<double>& xyz, const std::vector<std::array<int, 3>>& triangles,
                                  const std::vector<double>& corner_texcoords, double uv_scale);

/// The strain map's scale over `values` (appearance.json "strain_scale"): the percentile of
/// their absolute values over at most max_samples of them, every floor(n / max_samples)-th
/// from the first; 0 for none.
double strain_scale(const std::vector<double>& values);

/// strain_scale of values that arrive in parts (a frame at a time), keeping only those it
/// samples: `count` values in all.
class StrainScaleSampler {
 public:
  explicit StrainScaleSampler(size_t count);
  void add(const std::vector<double>& values);
  double scale() const;

 private:
  size_t step_ = 1, seen_ = 0;
  std::vector<double> sample_;  ///< |value| of every step_-th value
};

}  // namespace weft::render
