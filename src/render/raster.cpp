#include "weft/render/raster.hpp"

#include <cmath>
#include <stdexcept>

namespace weft::render {

Projection::Projection(const Camera& camera, int width, int height) : eye_(camera.eye) {
  forward_ = camera.target - camera.eye;
  if (!(forward_.norm() > 0)) throw std::invalid_argument("camera: the eye and the target are the same point");
  forward_.normalize();
  right_ = forward_.cross(camera.up);
  if (!(right_.norm() > 1e-9)) throw std::invalid_argument("camera: the view direction is parallel to up");
  right_.normalize();
  up_ = right_.cross(forward_);
  const double half_fov = 0.5 * camera.fov_deg * M_PI / 180;
  focal_px_ = 0.5 * height / std::tan(half_fov);
  cx_ = 0.5 * width;
  cy_ = 0.5 * height;
}

Vec3 Projection::to_view(const Vec3& p) const {
  const Vec3 d = p - eye_;
  return {d.dot(right_), d.dot(up_), d.dot(forward_)};
}

Vec2 Projection::to_pixels(const Vec3& view) const {
  return {cx_ + focal_px_ * view.x() / view.z(), cy_ - focal_px_ * view.y() / view.z()};
}

Vec3 Projection::ray(const Vec2& pixels) const {
  return forward_ + right_ * ((pixels.x() - cx_) / focal_px_) - up_ * ((pixels.y() - cy_) / focal_px_);
}

Framebuffer::Framebuffer(int width, int height, int samples_per_side)
    : width_(width), height_(height), samples_(samples_per_side) {
  if (width <= 0 || height <= 0 || samples_per_side <= 0) throw std::invalid_argument("framebuffer: empty size");
  const size_t n = static_cast<size_t>(sample_columns()) * sample_rows();
  colour.assign(n, Colour::Zero());
  depth.assign(n, std::numeric_limits<float>::infinity());
  shadowed.assign(n, 0);
}

namespace detail {

int clip_near(const std::array<Vec3, 3>& view, double near, std::array<Vec3, 4>& points, std::array<Vec3, 4>& bary) {
  static const std::array<Vec3, 3> corner{Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    const int next = (k + 1) % 3;
    const Vec3 &p = view[k], &q = view[next];
    const bool p_in = p.z() >= near, q_in = q.z() >= near;
    if (p_in) points[n] = p, bary[n] = corner[k], ++n;
    if (p_in != q_in) {
      const double t = (near - p.z()) / (q.z() - p.z());
      points[n] = p + t * (q - p);
      bary[n] = corner[k] + t * (corner[next] - corner[k]);
      ++n;
    }
  }
  return n;
}

}  // namespace detail

float srgb_encode(float linear) {
  const float c = std::clamp(linear, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1 / 2.4f) - 0.055f;
}

RgbImage resolve(const Framebuffer& fb, bool srgb) {
  RgbImage image(fb.width(), fb.height());
  const int s = fb.samples_per_side();
  const float weight = 1.0f / static_cast<float>(s * s);
  for (int y = 0; y < fb.height(); ++y)
    for (int x = 0; x < fb.width(); ++x) {
      Colour sum = Colour::Zero();
      for (int j = 0; j < s; ++j)
        for (int i = 0; i < s; ++i) sum += fb.colour[fb.sample_index(x * s + i, y * s + j)];
      std::uint8_t* px = image.at(x, y);
      for (int c = 0; c < 3; ++c) {
        const float v = std::clamp(sum[c] * weight, 0.0f, 1.0f);
        px[c] = static_cast<std::uint8_t>(std::lround(255 * (srgb ? srgb_encode(v) : v)));
      }
    }
  return image;
}

}  // namespace weft::render
