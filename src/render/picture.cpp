#include "weft/render/picture.hpp"

#include <algorithm>
#include <cmath>

#include "weft/exports.hpp"
#include "render/bitmap_font.hpp"

namespace weft::render {
namespace {

float smoothstep(float edge0, float edge1, float x) {
  const float t = std::clamp((x - edge0) / (edge1 - edge0), 0.0f, 1.0f);
  return t * t * (3 - 2 * t);
}

// The background: a vertical gradient, and the colour the ground fades into at its rim.
const Colour& sky_top() {
  static const Colour c = from_srgb(196, 208, 220);
  return c;
}
const Colour& horizon() {
  static const Colour c = from_srgb(236, 236, 232);
  return c;
}
const Colour& ground_colour() {
  static const Colour c = from_srgb(222, 220, 214);
  return c;
}

// Lights, in world axes, set from the camera so that every view is lit alike: a key light from
// above, to the left of and behind the viewer, and a headlight at the eye.
struct Lights {
  Vec3 key;  ///< unit, towards the light
};

Lights lights_for(const Projection& projection) {
  const Shading& s = shading();
  Vec3 key = s.key_right * projection.right() + Vec3(0, s.key_up, 0) - s.key_back * projection.forward();
  key.y() = std::max(key.y(), s.key_min_elevation * key.norm());
  return {key.normalized()};
}

// Lambert diffuse from the key light, the headlight and a sky/ground ambient, and a Blinn
// highlight from the key light; `n` unit and facing the viewer, `v` unit towards the eye.
Colour shade_surface(const Colour& base, const Vec3& n, const Vec3& v, const Lights& lights, double highlight,
                     double shininess) {
  const Shading& s = shading();
  const double ambient = s.ambient + s.ambient_up * n.y();
  const double key = s.key * std::max(0.0, n.dot(lights.key));
  const double head = s.headlight * std::max(0.0, n.dot(v));
  const Vec3 h = (lights.key + v).normalized();
  const double specular = n.dot(lights.key) > 0 ? highlight * std::pow(std::max(0.0, n.dot(h)), shininess) : 0.0;
  return base * static_cast<float>(ambient + key + head) + Colour::Constant(static_cast<float>(specular));
}

// The sky: the horizon's colour at and below the horizon (where the ground fades into it),
// turning to the sky's above it, by the elevation of each sample row's central ray.
void fill_background(Framebuffer& fb, const Projection& projection) {
  for (int row = 0; row < fb.sample_rows(); ++row) {
    const double y_px = (row + 0.5) / fb.samples_per_side();
    const Vec3 ray = projection.ray(Vec2(0.5 * fb.width(), y_px));
    const float elevation = static_cast<float>(std::asin(std::clamp(ray.normalized().y(), -1.0, 1.0)));
    const float t = smoothstep(-0.12f, 0.45f, elevation);
    const Colour c = (1 - t) * horizon() + t * sky_top();
    std::fill(fb.colour.begin() + static_cast<long>(fb.sample_index(0, row)),
              fb.colour.begin() + static_cast<long>(fb.sample_index(0, row) + fb.sample_columns()), c);
  }
}

// A square ground of half-size `half` around `centre` at height y, fading into the horizon's
// colour towards its rim.
void draw_ground(Framebuffer& fb, const Projection& projection, const Vec3& centre, double y, double half) {
  const std::array<Vec3, 4> corner{Vec3(centre.x() - half, y, centre.z() - half), Vec3(centre.x() + half, y, centre.z() - half),
                                   Vec3(centre.x() + half, y, centre.z() + half), Vec3(centre.x() - half, y, centre.z() + half)};
  for (const auto& tri : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
    const std::array<Vec3, 3> world{corner[tri[0]], corner[tri[1]], corner[tri[2]]};
    const std::array<Vec3, 3> view{projection.to_view(world[0]), projection.to_view(world[1]), projection.to_view(world[2])};
    draw_triangle(fb, projection, view, [&](const Vec3& b) {
      const Vec3 p = b[0] * world[0] + b[1] * world[1] + b[2] * world[2];
      const double r = std::hypot(p.x() - centre.x(), p.z() - centre.z()) / half;
      const float fade = smoothstep(0.15f, 0.8f, static_cast<float>(r));
      return Colour((1 - fade) * ground_colour() + fade * horizon());
    });
  }
}

// A separable box blur of the shadow flags, `radius` samples each way, as fractions.
std::vector<float> blurred_shadow(const Framebuffer& fb, int radius) {
  const int w = fb.sample_columns(), h = fb.sample_rows();
  std::vector<float> a(fb.shadowed.begin(), fb.shadowed.end()), b(a.size());
  const float norm = 1.0f / static_cast<float>(2 * radius + 1);
  for (int y = 0; y < h; ++y) {
    const float* in = a.data() + static_cast<size_t>(y) * w;
    float* out = b.data() + static_cast<size_t>(y) * w;
    float sum = 0;
    for (int x = -radius; x <= radius; ++x) sum += in[std::clamp(x, 0, w - 1)];
    for (int x = 0; x < w; ++x) {
      out[x] = sum * norm;
      sum += in[std::min(x + radius + 1, w - 1)] - in[std::max(x - radius, 0)];
    }
  }
  for (int x = 0; x < w; ++x) {
    float sum = 0;
    for (int y = -radius; y <= radius; ++y) sum += b[static_cast<size_t>(std::clamp(y, 0, h - 1)) * w + x];
    for (int y = 0; y < h; ++y) {
      a[static_cast<size_t>(y) * w + x] = sum * norm;
      sum += b[static_cast<size_t>(std::min(y + radius + 1, h - 1)) * w + x] -
             b[static_cast<size_t>(std::max(y - radius, 0)) * w + x];
    }
  }
  return a;
}

void draw_mesh(Framebuffer& fb, const Projection& projection, const Lights& lights, const PictureMesh& mesh) {
  const std::vector<double>& xyz = *mesh.xyz;
  const auto& triangles = *mesh.triangles;
  const int n = static_cast<int>(xyz.size() / 3);
  const std::vector<float> normals = vertex_normals(xyz.data(), n, triangles);
  std::vector<Vec3> world(static_cast<size_t>(n)), view(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    world[i] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    view[i] = projection.to_view(world[i]);
  }
  const bool cloth = mesh.surface == Surface::kCloth;
  const Colour own = cloth ? cloth_colour() : collider_colour();
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    const Vec3 face = (world[tri[1]] - world[tri[0]]).cross(world[tri[2]] - world[tri[0]]);
    if (!(face.norm() > 0)) continue;
    const Vec3 face_unit = face.normalized();
    const Vec3 centroid = (world[tri[0]] + world[tri[1]] + world[tri[2]]) / 3;
    // Two-sided: the side that faces the eye is shaded, its normal turned towards the eye.
    const bool front = face_unit.dot(projection.eye() - centroid) >= 0;
    const double side = front ? 1.0 : -1.0;
    std::array<Vec3, 3> corner_normal;
    for (int k = 0; k < 3; ++k) {
      const Vec3 vn(normals[3 * tri[k]], normals[3 * tri[k] + 1], normals[3 * tri[k] + 2]);
      // A collider's sharp edges (a box's) keep their faces flat: a vertex normal more than
      // about 45 degrees (collider_crease_cosine) from the face's is replaced by the face's.
      corner_normal[k] = (cloth || vn.dot(face_unit) > shading().collider_crease_cosine) ? vn : face_unit;
    }
    std::array<Colour, 3> corner_colour;
    for (int k = 0; k < 3; ++k) {
      corner_colour[k] = !mesh.triangle_colours.empty() ? mesh.triangle_colours[t]
                         : !mesh.vertex_colours.empty() ? mesh.vertex_colours[tri[k]]
                         : (cloth && !front)            ? cloth_back_colour()
                                                        : own;
      if (cloth && !front && (!mesh.triangle_colours.empty() || !mesh.vertex_colours.empty()))
        corner_colour[k] *= static_cast<float>(shading().coloured_back_factor);
    }
    const std::array<Vec3, 3> corners{view[tri[0]], view[tri[1]], view[tri[2]]};
    draw_triangle(fb, projection, corners, [&](const Vec3& b) {
      Vec3 normal = side * (b[0] * corner_normal[0] + b[1] * corner_normal[1] + b[2] * corner_normal[2]);
      // An interpolated normal that points away from the eye (at a silhouette) is bent back.
      const Vec3 p = b[0] * world[tri[0]] + b[1] * world[tri[1]] + b[2] * world[tri[2]];
      const Vec3 v = (projection.eye() - p).normalized();
      normal.normalize();
      if (normal.dot(v) < 0) normal = (normal - 1.01 * normal.dot(v) * v).normalized();
      const Colour base = b[0] * corner_colour[0] + b[1] * corner_colour[1] + b[2] * corner_colour[2];
      return cloth ? shade_surface(base, normal, v, lights, shading().cloth_highlight, shading().cloth_shininess)
                   : shade_surface(base, normal, v, lights, shading().collider_highlight, shading().collider_shininess);
    });
  }
}

void cast_shadows(Framebuffer& fb, const Projection& projection, const Lights& lights, const PictureMesh& mesh,
                  double ground_y, float tolerance) {
  const std::vector<double>& xyz = *mesh.xyz;
  auto on_ground = [&](int i) {
    const Vec3 p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    return projection.to_view(p - lights.key * (std::max(p.y(), ground_y) - ground_y) / lights.key.y());
  };
  std::vector<Vec3> view(xyz.size() / 3);
  for (size_t i = 0; i < view.size(); ++i) view[i] = on_ground(static_cast<int>(i));
  for (const auto& tri : *mesh.triangles)
    draw_triangle(fb, projection, {view[tri[0]], view[tri[1]], view[tri[2]]}, [](const Vec3&) { return Colour(); },
                  DepthMode::kShadow, tolerance);
}

std::array<std::uint8_t, 3> to_srgb_bytes(const Colour& c) {
  std::array<std::uint8_t, 3> out;
  for (int k = 0; k < 3; ++k) out[k] = static_cast<std::uint8_t>(std::lround(255 * srgb_encode(c[k])));
  return out;
}

void draw_colour_bar(RgbImage& image, const ColourBar& bar, int scale) {
  // Wide enough for both end labels side by side, and for the title.
  const int bar_w = std::max({image.width / 5, text_width(bar.low_label, scale) + text_width(bar.high_label, scale) + 4 * scale,
                              text_width(bar.title, scale) / 2}),
            bar_h = 3 * scale + 2;
  const int pad = 4 * scale, line = (kGlyphHeight + 3) * scale;
  const int x0 = image.width - pad - bar_w;
  const int y0 = image.height - pad - line - bar_h;
  if (x0 < 0 || y0 - line < 0 || bar.stops.size() < 2) return;
  const std::array<std::uint8_t, 3> ink{60, 60, 60};
  for (int x = 0; x < bar_w; ++x) {
    const double f = static_cast<double>(x) / (bar_w - 1) * static_cast<double>(bar.stops.size() - 1);
    const size_t k = std::min(static_cast<size_t>(f), bar.stops.size() - 2);
    const float w = static_cast<float>(f - static_cast<double>(k));
    const auto rgb = to_srgb_bytes((1 - w) * bar.stops[k] + w * bar.stops[k + 1]);
    for (int y = 0; y < bar_h; ++y) std::copy(rgb.begin(), rgb.end(), image.at(x0 + x, y0 + y));
  }
  draw_label(image, x0 + bar_w - text_width(bar.title, scale), y0 - line, bar.title, scale, ink);
  draw_label(image, x0, y0 + bar_h + 2 * scale, bar.low_label, scale, ink);
  draw_label(image, x0 + bar_w - text_width(bar.high_label, scale), y0 + bar_h + 2 * scale, bar.high_label, scale, ink);
}

}  // namespace

Bounds bounds_of(const std::vector<double>& xyz) {
  Bounds b;
  for (size_t i = 0; i + 2 < xyz.size(); i += 3) b.add(Vec3(xyz[i], xyz[i + 1], xyz[i + 2]));
  return b;
}

void draw_label(RgbImage& image, int x, int y, const std::string& text, int scale, const std::array<std::uint8_t, 3>& ink) {
  const int w = text_width(text, scale), h = kGlyphHeight * scale;
  if (w <= 0) return;
  GrayImage mask(w, h, 0);
  draw_text(mask, 0, 0, text, scale, 255);
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i)
      if (mask.at(i, j) && x + i >= 0 && y + j >= 0 && x + i < image.width && y + j < image.height)
        std::copy(ink.begin(), ink.end(), image.at(x + i, y + j));
}

Camera frame_camera(const Bounds& box_in, int width, int height, double fov_deg, double azimuth_deg, double elevation_deg,
                    double margin) {
  Bounds box = box_in;
  if (box.empty()) box.add(Vec3::Zero());
  // A box smaller than 10 cm across is framed as one of 10 cm.
  const Vec3 pad = (Vec3::Constant(0.1) - (box.hi - box.lo)).cwiseMax(0.0) / 2;
  box.lo -= pad, box.hi += pad;
  const double az = azimuth_deg * M_PI / 180, el = elevation_deg * M_PI / 180;
  const Vec3 to_eye(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  const Vec3 forward = -to_eye;
  const Vec3 right = forward.cross(Vec3::UnitY()).normalized();
  const Vec3 up = right.cross(forward);
  std::array<Vec3, 8> corners;
  for (int k = 0; k < 8; ++k)
    corners[k] = Vec3(k & 1 ? box.hi.x() : box.lo.x(), k & 2 ? box.hi.y() : box.lo.y(), k & 4 ? box.hi.z() : box.lo.z());
  // The target: the middle of the box's extent across the view.
  Vec3 target = box.centre();
  double r_lo = 1e300, r_hi = -1e300, u_lo = 1e300, u_hi = -1e300;
  for (const Vec3& c : corners) {
    r_lo = std::min(r_lo, (c - target).dot(right)), r_hi = std::max(r_hi, (c - target).dot(right));
    u_lo = std::min(u_lo, (c - target).dot(up)), u_hi = std::max(u_hi, (c - target).dot(up));
  }
  target += 0.5 * (r_lo + r_hi) * right + 0.5 * (u_lo + u_hi) * up;
  // A corner at (x, y) across the view and z towards the eye from the target lies inside the
  // picture when |x| <= tan_h (d - z) and |y| <= tan_v (d - z).
  const double tan_v = std::tan(0.5 * fov_deg * M_PI / 180) * (1 - margin);
  const double tan_h = tan_v * width / height;
  double distance = 0;
  for (const Vec3& c : corners) {
    const Vec3 q = c - target;
    distance = std::max({distance, std::abs(q.dot(right)) / tan_h + q.dot(to_eye), std::abs(q.dot(up)) / tan_v + q.dot(to_eye)});
  }
  Camera camera;
  camera.target = target;
  camera.eye = target + distance * to_eye;
  camera.fov_deg = fov_deg;
  return camera;
}

RgbImage render_picture(const std::vector<PictureMesh>& meshes, const PictureOptions& options) {
  Framebuffer fb(options.width, options.height, options.samples_per_side);
  Projection projection(options.camera, options.width, options.height);
  const double reach = (options.camera.target - options.camera.eye).norm();
  projection.set_near(std::max(1e-4, 1e-3 * reach));
  const Lights lights = lights_for(projection);
  fill_background(fb, projection);
  std::vector<float> ground_depth;
  if (options.ground_y && !options.scene_bounds.empty()) {
    const Bounds& b = options.scene_bounds;
    const double extent = std::max({b.hi.x() - b.lo.x(), b.hi.z() - b.lo.z(), b.hi.y() - b.lo.y(), 0.25});
    draw_ground(fb, projection, b.centre(), *options.ground_y, 5 * extent);
    ground_depth = fb.depth;
    const float tolerance = static_cast<float>(1e-4 * reach);
    for (const PictureMesh& m : meshes) cast_shadows(fb, projection, lights, m, *options.ground_y, tolerance);
  }
  for (const PictureMesh& m : meshes) draw_mesh(fb, projection, lights, m);
  if (!ground_depth.empty()) {
    const int radius = std::max(1, fb.samples_per_side() * options.height / 150);
    const std::vector<float> shadow = blurred_shadow(fb, radius);
    for (size_t i = 0; i < fb.depth.size(); ++i)
      if (std::isfinite(ground_depth[i]) && fb.depth[i] == ground_depth[i]) fb.colour[i] *= 1 - 0.35f * shadow[i];
  }
  RgbImage image = resolve(fb);
  const int scale = std::max(1, (options.height + 150) / 300);
  if (!options.caption.empty())
    draw_label(image, 4 * scale, options.height - (4 + kGlyphHeight) * scale, options.caption, scale, {60, 60, 60});
  if (options.colour_bar) draw_colour_bar(image, *options.colour_bar, scale);
  return image;
}

}  // namespace weft::render
