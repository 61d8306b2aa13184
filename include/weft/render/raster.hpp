#pragma once
// A software rasteriser for `weft render` (docs/render.md): a pinhole camera, triangles clipped
// at the near plane, drawn into a supersampled framebuffer with a depth buffer, and resolved
// into an 8-bit image by averaging each pixel's samples.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "weft/gray_image.hpp"
#include "weft/types.hpp"

namespace weft::render {

/// A linear RGB colour, each channel in [0, 1].
using Colour = Eigen::Vector3f;

/// A pinhole camera looking from `eye` at `target`, `up` giving the picture's vertical.
struct Camera {
  Vec3 eye{0, 0, 1};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  double fov_deg = 30;  ///< vertical field of view
};

/// The camera's frame and its projection onto a picture of width x height pixels (x to the
/// right, y down, pixel (0, 0) covering [0, 1) x [0, 1)).
class Projection {
 public:
  Projection(const Camera& camera, int width, int height);
  /// A world point in camera axes: (right, up, distance in front of the eye).
  Vec3 to_view(const Vec3& p) const;
  /// A point in camera axes (z > 0) on the picture, in pixels.
  Vec2 to_pixels(const Vec3& view) const;
  /// The direction (world axes, not unit) of the ray from the eye through a point on the picture.
  Vec3 ray(const Vec2& pixels) const;
  const Vec3& eye() const { return eye_; }
  /// Unit vectors of the camera: right, up, and forward (from the eye towards the target).
  const Vec3& right() const { return right_; }
  const Vec3& up() const { return up_; }
  const Vec3& forward() const { return forward_; }
  /// Distance in front of the eye below which geometry is clipped away.
  double near() const { return near_; }
  void set_near(double near_m) { near_ = near_m; }

 private:
  Vec3 eye_, right_, up_, forward_;
  double focal_px_ = 1, cx_ = 0, cy_ = 0, near_ = 1e-3;
};

/// The supersampled picture: `samples_per_side`^2 samples per pixel on a regular grid, each
/// with a linear colour, a depth (distance in front of the eye) and a flag that a shadow was
/// cast on it.
class Framebuffer {
 public:
  Framebuffer(int width, int height, int samples_per_side);
  int width() const { return width_; }
  int height() const { return height_; }
  int samples_per_side() const { return samples_; }
  int sample_columns() const { return width_ * samples_; }
  int sample_rows() const { return height_ * samples_; }
  size_t sample_index(int column, int row) const { return static_cast<size_t>(row) * sample_columns() + column; }

  std::vector<Colour> colour;  ///< per sample, row-major
  std::vector<float> depth;    ///< per sample; +infinity where nothing was drawn
  std::vector<std::uint8_t> shadowed;

 private:
  int width_, height_, samples_;
};

/// How a triangle's samples meet the depth buffer.
enum class DepthMode {
  kNearest,  ///< drawn where nearer than what is there (depth test), depth written
  kShadow,   ///< marks `shadowed` where it lies on (within `shadow_tolerance` of) what is there; no colour
};

/// One corner of a triangle to draw: its position in camera axes (Projection::to_view).
struct RasterCorner {
  Vec3 view;
};

/// Draws a triangle given by its corners in camera axes, clipped at the projection's near
/// plane. Samples whose centre lies inside (a sample on an edge shared by two triangles
/// belongs to exactly one of them) and that pass the depth test call `shade(b)` with the
/// perspective-correct barycentric coordinates b of the sample in the triangle, which returns
/// the sample's colour.
template <class Shade>
void draw_triangle(Framebuffer& fb, const Projection& projection, const std::array<Vec3, 3>& view, Shade&& shade,
                   DepthMode mode = DepthMode::kNearest, float shadow_tolerance = 0);

/// The picture: each pixel the mean of its samples' linear colours, encoded as sRGB when
/// `srgb` (or kept linear, value = 255 * mean, for measurements).
RgbImage resolve(const Framebuffer& fb, bool srgb = true);

/// sRGB encoding of a linear value in [0, 1].
float srgb_encode(float linear);

// ---------------------------------------------------------------------------------------------

namespace detail {

/// A corner after clipping: pixel position in sample units, 1 / depth, and the barycentric
/// coordinates of the corner in the original triangle.
struct ScreenCorner {
  double x, y, inv_depth;
  Vec3 bary;
};

/// Clips the triangle at z = near (Sutherland-Hodgman against one plane): 0, 3 or 4 corners.
int clip_near(const std::array<Vec3, 3>& view, double near, std::array<Vec3, 4>& points, std::array<Vec3, 4>& bary);

template <class Shade>
void fill(Framebuffer& fb, const ScreenCorner& a, const ScreenCorner& b0, const ScreenCorner& c0, Shade& shade,
          DepthMode mode, float shadow_tolerance) {
  // Counter-clockwise on the picture (y down): a positive signed area.
  const double area0 = (b0.x - a.x) * (c0.y - a.y) - (b0.y - a.y) * (c0.x - a.x);
  if (!(area0 != 0)) return;
  const ScreenCorner& b = area0 > 0 ? b0 : c0;
  const ScreenCorner& c = area0 > 0 ? c0 : b0;
  const double area = std::abs(area0);
  // The bounding box of samples, clamped to the picture in floating point (a corner close to the
  // near plane can project far outside it).
  const double columns = fb.sample_columns() - 1, rows = fb.sample_rows() - 1;
  const int x_min = static_cast<int>(std::clamp(std::floor(std::min({a.x, b.x, c.x})), 0.0, columns + 1));
  const int y_min = static_cast<int>(std::clamp(std::floor(std::min({a.y, b.y, c.y})), 0.0, rows + 1));
  const int x_max = static_cast<int>(std::clamp(std::ceil(std::max({a.x, b.x, c.x})), -1.0, columns));
  const int y_max = static_cast<int>(std::clamp(std::ceil(std::max({a.y, b.y, c.y})), -1.0, rows));
  if (x_min > x_max || y_min > y_max) return;
  // Edge function of the edge p -> q at a sample s, (q - p) x (s - p): positive inside, and
  // the edge opposite a corner's weight (twice the area of the sub-triangle).
  struct Edge {
    double dx, dy, offset;
    bool inclusive;
    double at(double x, double y) const { return dx * (y) - dy * (x) + offset; }
  };
  auto edge = [](const ScreenCorner& p, const ScreenCorner& q) {
    Edge e;
    // (q - p) x (s - p) > 0 for s to the left of p -> q in y-down axes, i.e. inside.
    e.dx = q.x - p.x;
    e.dy = q.y - p.y;
    e.offset = -(e.dx * p.y - e.dy * p.x);
    // Tie-break for samples exactly on an edge: an edge shared by two triangles is seen in
    // opposite directions by the two, so exactly one of them owns it.
    e.inclusive = e.dy > 0 || (e.dy == 0 && e.dx < 0);
    return e;
  };
  const Edge ea = edge(b, c), eb = edge(c, a), ec = edge(a, b);
  for (int y = y_min; y <= y_max; ++y) {
    const double sy = y + 0.5;
    for (int x = x_min; x <= x_max; ++x) {
      const double sx = x + 0.5;
      const double wa = ea.at(sx, sy), wb = eb.at(sx, sy), wc = ec.at(sx, sy);
      if (wa < 0 || wb < 0 || wc < 0) continue;
      if ((wa == 0 && !ea.inclusive) || (wb == 0 && !eb.inclusive) || (wc == 0 && !ec.inclusive)) continue;
      const double la = wa / area, lb = wb / area, lc = wc / area;
      const double inv_depth = la * a.inv_depth + lb * b.inv_depth + lc * c.inv_depth;
      if (!(inv_depth > 0)) continue;
      const float depth = static_cast<float>(1 / inv_depth);
      const size_t i = fb.sample_index(x, y);
      if (mode == DepthMode::kShadow) {
        if (depth <= fb.depth[i] + shadow_tolerance) fb.shadowed[i] = 1;
        continue;
      }
      if (!(depth < fb.depth[i])) continue;
      // Perspective-correct: attributes over depth are linear on the picture.
      const Vec3 bary = (la * a.inv_depth * a.bary + lb * b.inv_depth * b.bary + lc * c.inv_depth * c.bary) / inv_depth;
      fb.depth[i] = depth;
      fb.shadowed[i] = 0;
      fb.colour[i] = shade(bary);
    }
  }
}

}  // namespace detail

template <class Shade>
void draw_triangle(Framebuffer& fb, const Projection& projection, const std::array<Vec3, 3>& view, Shade&& shade,
                   DepthMode mode, float shadow_tolerance) {
  std::array<Vec3, 4> points, bary;
  const int n = detail::clip_near(view, projection.near(), points, bary);
  if (n < 3) return;
  const double s = fb.samples_per_side();
  std::array<detail::ScreenCorner, 4> screen;
  for (int k = 0; k < n; ++k) {
    const Vec2 px = projection.to_pixels(points[k]) * s;
    screen[k] = {px.x(), px.y(), 1 / points[k].z(), bary[k]};
  }
  for (int k = 1; k + 1 < n; ++k) detail::fill(fb, screen[0], screen[k], screen[k + 1], shade, mode, shadow_tolerance);
}

}  // namespace weft::render
