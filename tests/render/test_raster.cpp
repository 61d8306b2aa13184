// The software rasteriser of `weft render`: coverage of a known triangle against its area, the
// depth test, clipping at the near plane, the automatic framing, and the stretch measure of the
// strain colour map.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/render/picture.hpp"
#include "weft/render/raster.hpp"

using weft::Vec2;
using weft::RgbImage;
using weft::Vec3;
using namespace weft::render;

namespace {

constexpr int kSize = 64;

// A camera at the origin looking down -Z with a 60 degree field of view on a kSize x kSize
// picture, and the point at distance z in front of it that lands on pixel position (px, py).
struct PixelScene {
  Camera camera;
  Projection projection;
  double focal;
  PixelScene()
      : camera{Vec3(0, 0, 0), Vec3(0, 0, -1), Vec3(0, 1, 0), 60},
        projection(camera, kSize, kSize),
        focal(0.5 * kSize / std::tan(M_PI / 6)) {}
  Vec3 view_at(double px, double py, double z) const {
    return Vec3((px - 0.5 * kSize) / focal * z, (0.5 * kSize - py) / focal * z, z);
  }
};

double shoelace(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t k = 0; k < p.size(); ++k) {
    const Vec2 &u = p[k], &v = p[(k + 1) % p.size()];
    a += u.x() * v.y() - u.y() * v.x();
  }
  return 0.5 * std::abs(a);
}

// Sum over the picture of a channel's value in [0, 1] (a linear resolve): the covered area in
// pixels when the triangle is white on black.
double covered_area(const RgbImage& image, int channel) {
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) sum += image.at(x, y)[channel] / 255.0;
  return sum;
}

TEST(Raster, CoverageOfATriangleIsItsArea) {
  const PixelScene scene;
  const std::vector<std::vector<Vec2>> triangles{
      {Vec2(10.2, 8.7), Vec2(52.9, 20.3), Vec2(25.4, 55.1)},
      {Vec2(3.5, 60.2), Vec2(60.7, 58.9), Vec2(31.1, 2.4)},
      {Vec2(5.3, 5.1), Vec2(58.6, 41.7), Vec2(9.9, 12.2)},  // long and thin
  };
  for (const auto& t : triangles) {
    const double area = shoelace(t);
    for (int samples : {1, 2, 4, 8}) {
      Framebuffer fb(kSize, kSize, samples);
      std::array<Vec3, 3> view;
      for (int k = 0; k < 3; ++k) view[k] = scene.view_at(t[k].x(), t[k].y(), 1.5 + 0.5 * k);
      draw_triangle(fb, scene.projection, view, [](const Vec3&) { return Colour(1, 1, 1); });
      const RgbImage image = resolve(fb, false);
      // Point sampling on an s x s grid: along an edge spanning D pixels in its dominant
      // direction, each of the D s columns (or rows) of samples it crosses miscounts the
      // area under it by at most one sample, 1/s^2 pixels (the column's midpoint is exact for
      // a straight edge), plus the partial columns at its ends; and each touched pixel rounds
      // to 1/255.
      double bound = 0, touched = 0;
      for (int k = 0; k < 3; ++k) {
        const Vec2 d = t[(k + 1) % 3] - t[k];
        bound += (std::max(std::abs(d.x()), std::abs(d.y())) * samples + 2) / (samples * samples);
        touched += d.norm() + 2;
      }
      bound += (area + touched) * 0.5 / 255;
      EXPECT_NEAR(covered_area(image, 0), area, bound) << "samples " << samples << ", area " << area;
    }
  }
}

TEST(Raster, TrianglesSharingAnEdgeCoverEachSampleOnce) {
  // A square as two triangles, drawn additively: a sample counted twice would show as 2.
  const PixelScene scene;
  Framebuffer fb(kSize, kSize, 2);
  std::vector<int> hits(fb.depth.size(), 0);
  const std::array<Vec2, 4> q{Vec2(8, 8), Vec2(56, 8), Vec2(56, 56), Vec2(8, 56)};
  for (const auto& tri : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
    std::array<Vec3, 3> view;
    for (int k = 0; k < 3; ++k) view[k] = scene.view_at(q[tri[k]].x(), q[tri[k]].y(), 2);
    draw_triangle(fb, scene.projection, view, [](const Vec3&) { return Colour(1, 1, 1); });
    for (size_t i = 0; i < fb.depth.size(); ++i) hits[i] += std::isfinite(fb.depth[i]) ? 1 : 0, fb.depth[i] = INFINITY;
  }
  int twice = 0, once = 0;
  for (int h : hits) twice += h > 1, once += h == 1;
  EXPECT_EQ(twice, 0);
  // Samples at half-integer positions in sample units: 48 pixels x 2 = 96 per side.
  EXPECT_EQ(once, 96 * 96);
}

TEST(Raster, TheNearerTriangleHidesTheFartherInEitherOrder) {
  const PixelScene scene;
  const std::array<Vec2, 3> t{Vec2(4, 4), Vec2(60, 10), Vec2(20, 60)};
  for (bool near_first : {true, false}) {
    Framebuffer fb(kSize, kSize, 2);
    auto draw = [&](double z, const Colour& c) {
      std::array<Vec3, 3> view;
      for (int k = 0; k < 3; ++k) view[k] = scene.view_at(t[k].x(), t[k].y(), z);
      draw_triangle(fb, scene.projection, view, [&](const Vec3&) { return c; });
    };
    if (near_first) draw(1.0, Colour(1, 0, 0));
    draw(3.0, Colour(0, 1, 0));
    if (!near_first) draw(1.0, Colour(1, 0, 0));
    const RgbImage image = resolve(fb, false);
    double green = covered_area(image, 1), red = covered_area(image, 0);
    EXPECT_EQ(green, 0) << "near first: " << near_first;
    EXPECT_GT(red, 0.9 * shoelace({t[0], t[1], t[2]}));
  }
}

TEST(Raster, PerspectiveCorrectBarycentricsGiveTheSurfacePoint) {
  // A triangle slanted in depth: the barycentric point of each sample lies on the sample's
  // ray through the eye.
  const PixelScene scene;
  Framebuffer fb(kSize, kSize, 1);
  const std::array<Vec3, 3> view{scene.view_at(5, 5, 1), scene.view_at(60, 12, 6), scene.view_at(12, 60, 3)};
  double worst = 0;
  draw_triangle(fb, scene.projection, view, [&](const Vec3& b) {
    const Vec3 p = b[0] * view[0] + b[1] * view[1] + b[2] * view[2];
    const Vec2 px = scene.projection.to_pixels(p);
    // A sample centre lies at a half-integer position.
    worst = std::max({worst, std::abs(px.x() - std::floor(px.x()) - 0.5), std::abs(px.y() - std::floor(px.y()) - 0.5)});
    return Colour(1, 1, 1);
  });
  EXPECT_LT(worst, 1e-9);
}

TEST(Raster, ClipsAtTheNearPlane) {
  const PixelScene scene;
  // Entirely behind the eye: nothing drawn.
  Framebuffer behind(kSize, kSize, 1);
  draw_triangle(behind, scene.projection, {Vec3(-1, -1, -2), Vec3(1, -1, -2), Vec3(0, 1, -2)},
                [](const Vec3&) { return Colour(1, 1, 1); });
  for (float d : behind.depth) EXPECT_TRUE(std::isinf(d));
  // Crossing the near plane: the part in front is drawn, each drawn sample in front of it.
  Framebuffer crossing(kSize, kSize, 1);
  draw_triangle(crossing, scene.projection, {Vec3(-1, -0.2, 2), Vec3(1, -0.2, 2), Vec3(0, -0.2, -2)},
                [](const Vec3&) { return Colour(1, 1, 1); });
  int drawn = 0;
  float nearest = INFINITY;
  for (float d : crossing.depth)
    if (std::isfinite(d)) ++drawn, nearest = std::min(nearest, d);
  EXPECT_GT(drawn, 0);
  EXPECT_GE(nearest, scene.projection.near() * (1 - 1e-6));
}

TEST(Picture, FrameCameraKeepsEveryCornerInsideWithTheMargin) {
  Bounds box;
  box.add(Vec3(-0.3, 0.4, -0.2));
  box.add(Vec3(0.5, 1.6, 0.3));
  for (auto [w, h] : {std::pair{960, 720}, std::pair{400, 800}}) {
    const double margin = 0.1;
    const Camera camera = frame_camera(box, w, h, 30, 35, 20, margin);
    const Projection projection(camera, w, h);
    double reach = 0;  // the largest fraction of the half width or height a corner reaches
    for (int k = 0; k < 8; ++k) {
      const Vec3 c(k & 1 ? box.hi.x() : box.lo.x(), k & 2 ? box.hi.y() : box.lo.y(), k & 4 ? box.hi.z() : box.lo.z());
      const Vec3 v = projection.to_view(c);
      ASSERT_GT(v.z(), 0);
      const Vec2 px = projection.to_pixels(v);
      reach = std::max({reach, std::abs(px.x() - 0.5 * w) / (0.5 * w), std::abs(px.y() - 0.5 * h) / (0.5 * h)});
    }
    // Inside the margin; and tight: the target is centred on the box's extent across the view
    // (not on its perspective image), so a corner reaches the margin up to that asymmetry.
    EXPECT_LE(reach, 1 - margin + 1e-9);
    EXPECT_GT(reach, 0.75 * (1 - margin));
  }
}

TEST(Picture, LargestPrincipalStretch) {
  const Vec2 u0(0, 0), u1(0.1, 0), u2(0, 0.1);
  // At rest, in any placement.
  const Eigen::AngleAxisd turn(0.7, Vec3(1, 2, 3).normalized());
  auto placed = [&](const Vec2& u) { return Vec3(turn * Vec3(u.x(), u.y(), 0) + Vec3(1, 2, 3)); };
  EXPECT_NEAR(largest_principal_stretch(placed(u0), placed(u1), placed(u2), u0, u1, u2), 1, 1e-12);
  // Stretched 20% along u and compressed along v: 1.2.
  auto stretched = [&](const Vec2& u) { return placed(Vec2(1.2 * u.x(), 0.9 * u.y())); };
  EXPECT_NEAR(largest_principal_stretch(stretched(u0), stretched(u1), stretched(u2), u0, u1, u2), 1.2, 1e-12);
  // A simple shear by gamma: the largest singular value of [[1, gamma], [0, 1]].
  const double g = 0.3;
  auto sheared = [&](const Vec2& u) { return placed(Vec2(u.x() + g * u.y(), u.y())); };
  const double expected = 0.5 * (g + std::sqrt(g * g + 4));
  EXPECT_NEAR(largest_principal_stretch(sheared(u0), sheared(u1), sheared(u2), u0, u1, u2), expected, 1e-12);
  EXPECT_TRUE(std::isnan(largest_principal_stretch(placed(u0), placed(u1), placed(u2), u0, u1, 2 * u1)));
}

}  // namespace
