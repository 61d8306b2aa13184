#pragma once
// Shaded pictures of a run's frame for `weft render` (docs/render.md): the cloth two-sided in a
// fabric colour (or a colour map), the colliders in grey, lit by a key light and a headlight
// (Lambert diffuse, a Blinn highlight; colours and constants from appearance.hpp, as the
// viewer's), over a ground that fades into the background and takes
// the objects' shadows from the key light; a caption and a colour bar drawn in the bitmap font.
#include <array>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "weft/render/appearance.hpp"
#include "weft/render/raster.hpp"

namespace weft::render {

/// An axis-aligned box; empty until a point is added.
struct Bounds {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void add(const Vec3& p) { lo = lo.cwiseMin(p), hi = hi.cwiseMax(p); }
  void add(const Bounds& b) {
    if (!b.empty()) add(b.lo), add(b.hi);
  }
  bool empty() const { return !(lo.x() <= hi.x()); }
  Vec3 centre() const { return 0.5 * (lo + hi); }
};

/// The bounds of 3 coordinates per point.
Bounds bounds_of(const std::vector<double>& xyz);

enum class Surface { kCloth, kCollider };

/// One mesh of a picture. Its colour is, by priority, per triangle, per vertex, or the
/// surface's own (a fabric colour for the cloth, grey for colliders).
struct PictureMesh {
  const std::vector<double>* xyz = nullptr;                     ///< 3 per vertex
  const std::vector<std::array<int, 3>>* triangles = nullptr;  ///< 0-based
  Surface surface = Surface::kCloth;
  std::vector<Colour> vertex_colours;    ///< one per vertex, or empty
  std::vector<Colour> triangle_colours;  ///< one per triangle, or empty
};

/// A colour bar: `stops` colours spread evenly from the low to the high end, labelled.
struct ColourBar {
  std::string title, low_label, high_label;
  std::vector<Colour> stops;
};

struct PictureOptions {
  int width = 960, height = 720;
  int samples_per_side = 3;  ///< supersampling: samples_per_side^2 samples per pixel
  Camera camera;
  /// A ground plane at this height under `scene_bounds`, with the shadows; none when empty.
  std::optional<double> ground_y;
  Bounds scene_bounds;
  std::string caption;  ///< bottom left, in the bitmap font's characters
  std::optional<ColourBar> colour_bar;
};

/// The picture of `meshes` seen by `options.camera`.
RgbImage render_picture(const std::vector<PictureMesh>& meshes, const PictureOptions& options);

/// A camera that frames `box` in a width x height picture with a vertical field of view of
/// `fov_deg`: looking at the box from the front (+Z, the mannequin's facing) turned by
/// `azimuth_deg` towards +X and raised by `elevation_deg`, Y up, from the distance at which
/// every corner of the box lies inside the picture with `margin` (a fraction of the half
/// width and height) to spare.
Camera frame_camera(const Bounds& box, int width, int height, double fov_deg = 30, double azimuth_deg = 35,
                    double elevation_deg = 20, double margin = 0.12);

/// Draws `text` in the bitmap font (bitmap_font.hpp) at (x, y) (top-left), `scale` pixels per
/// font pixel, in `ink` (sRGB bytes).
void draw_label(RgbImage& image, int x, int y, const std::string& text, int scale, const std::array<std::uint8_t, 3>& ink);

}  // namespace weft::render
