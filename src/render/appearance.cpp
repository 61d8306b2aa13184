#include "weft/render/appearance.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

namespace weft::render {
namespace {

// src/render/appearance.json, as a raw string literal the build writes (CMakeLists.txt).
const char kAppearanceJson[] =
#include "render/appearance_json.inc"
    ;

struct Appearance {
  std::vector<std::array<double, 3>> sequential, diverging;  // sRGB stops, 0..255
  double strain_percentile = 99;
  size_t strain_max_samples = 200000;
  Colour cloth_front, cloth_back, collider;
  Shading shading;
};

std::array<double, 3> srgb_triple(const nlohmann::json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

// Parsed once; a malformed file is a build error caught by the tests, not a user's input.
const Appearance& appearance() {
  static const Appearance a = [] {
    const nlohmann::json j = nlohmann::json::parse(kAppearanceJson);
    Appearance out;
    const auto& maps = j.at("colour_maps");
    for (const auto& s : maps.at("sequential").at("stops_srgb")) out.sequential.push_back(srgb_triple(s));
    for (const auto& s : maps.at("diverging").at("stops_srgb")) out.diverging.push_back(srgb_triple(s));
    out.strain_percentile = maps.at("strain_scale").at("percentile").get<double>();
    out.strain_max_samples = maps.at("strain_scale").at("max_samples").get<size_t>();
    auto colour = [&](const char* name) {
      const auto c = srgb_triple(j.at("colours_srgb").at(name));
      return from_srgb(static_cast<int>(c[0]), static_cast<int>(c[1]), static_cast<int>(c[2]));
    };
    out.cloth_front = colour("cloth_front");
    out.cloth_back = colour("cloth_back");
    out.collider = colour("collider");
    const auto& s = j.at("shading");
    Shading& sh = out.shading;
    sh.ambient = s.at("ambient").get<double>();
    sh.ambient_up = s.at("ambient_up").get<double>();
    sh.key = s.at("key").get<double>();
    sh.headlight = s.at("headlight").get<double>();
    sh.key_right = s.at("key_direction").at("right").get<double>();
    sh.key_up = s.at("key_direction").at("up").get<double>();
    sh.key_back = s.at("key_direction").at("back").get<double>();
    sh.key_min_elevation = s.at("key_min_elevation").get<double>();
    sh.cloth_highlight = s.at("cloth").at("highlight").get<double>();
    sh.cloth_shininess = s.at("cloth").at("shininess").get<double>();
    sh.collider_highlight = s.at("collider").at("highlight").get<double>();
    sh.collider_shininess = s.at("collider").at("shininess").get<double>();
    sh.coloured_back_factor = s.at("coloured_back_factor").get<double>();
    sh.collider_crease_cosine = s.at("collider_crease_cosine").get<double>();
    return out;
  }();
  return a;
}

float srgb_decode(double byte) {
  const double c = byte / 255;
  return static_cast<float>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

// `t` in [0, 1] along evenly spaced stops, interpolated in sRGB and decoded to linear.
Colour ramp(const std::vector<std::array<double, 3>>& stops, double t) {
  const double x = std::clamp(t, 0.0, 1.0) * static_cast<double>(stops.size() - 1);
  const size_t k = std::min(static_cast<size_t>(x), stops.size() - 2);
  const double a = x - static_cast<double>(k);
  Colour c;
  for (int d = 0; d < 3; ++d) c[d] = srgb_decode(stops[k][d] * (1 - a) + stops[k + 1][d] * a);
  return c;
}

}  // namespace

const std::string& appearance_json() {
  static const std::string text = kAppearanceJson;
  return text;
}

const Shading& shading() { return appearance().shading; }

Colour from_srgb(int r, int g, int b) { return {srgb_decode(r), srgb_decode(g), srgb_decode(b)}; }

Colour cloth_colour() { return appearance().cloth_front; }
Colour cloth_back_colour() { return appearance().cloth_back; }
Colour collider_colour() { return appearance().collider; }

Colour sequential_colour(double fraction) {
  return ramp(appearance().sequential, std::isnan(fraction) ? 0.0 : fraction);
}

Colour diverging_colour(double signed_fraction) {
  return ramp(appearance().diverging, std::isnan(signed_fraction) ? 0.5 : 0.5 * (signed_fraction + 1));
}

double largest_principal_stretch(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec2& u0, const Vec2& u1,
                                 const Vec2& u2) {
  Mat2 du;
  du << u1 - u0, u2 - u0;
  const double det = du.determinant();
  if (!(std::abs(det) > 0)) return std::nan("");
  Eigen::Matrix<double, 3, 2> dx;
  dx << x1 - x0, x2 - x0;
  const Eigen::Matrix<double, 3, 2> f = dx * du.inverse();
  // The largest eigenvalue of the right Cauchy-Green tensor F^T F, a symmetric 2 x 2.
  const Mat2 c = f.transpose() * f;
  const double mean = 0.5 * (c(0, 0) + c(1, 1)), half_diff = 0.5 * (c(0, 0) - c(1, 1));
  return std::sqrt(mean + std::sqrt(half_diff * half_diff + c(0, 1) * c(0, 1)));
}

std::vector<double> vertex_strain(const std::vector<double>& xyz, const std::vector<std::array<int, 3>>& triangles,
                                  const std::vector<double>& corner_texcoords, double uv_scale) {
  const size_t n = xyz.size() / 3;
  std::vector<double> sum(n, 0.0), weight(n, 0.0);
  for (size_t t = 0; t < triangles.size(); ++t) {
    std::array<Vec3, 3> x;
    std::array<Vec2, 3> u;
    for (int k = 0; k < 3; ++k) {
      const int i = triangles[t][k];
      x[k] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
      u[k] = uv_scale * Vec2(corner_texcoords[6 * t + 2 * k], corner_texcoords[6 * t + 2 * k + 1]);
    }
    const Vec2 e1 = u[1] - u[0], e2 = u[2] - u[0];
    const double area = 0.5 * std::abs(e1.x() * e2.y() - e2.x() * e1.y());
    if (!(area > 1e-14)) continue;
    const double strain = largest_principal_stretch(x[0], x[1], x[2], u[0], u[1], u[2]) - 1;
    for (int k = 0; k < 3; ++k) sum[triangles[t][k]] += area * strain, weight[triangles[t][k]] += area;
  }
  for (size_t i = 0; i < n; ++i) sum[i] = weight[i] > 0 ? sum[i] / weight[i] : 0.0;
  return sum;
}

StrainScaleSampler::StrainScaleSampler(size_t count)
    : step_(std::max<size_t>(1, count / appearance().strain_max_samples)) {
  sample_.reserve(count / step_ + 1);
}

void StrainScaleSampler::add(const std::vector<double>& values) {
  // The values' indices in the whole sequence are seen_ .. seen_ + n - 1; every step_-th from 0.
  for (size_t k = (step_ - seen_ % step_) % step_; k < values.size(); k += step_) sample_.push_back(std::abs(values[k]));
  seen_ += values.size();
}

double StrainScaleSampler::scale() const {
  if (sample_.empty()) return 0;
  std::vector<double> sample = sample_;
  const size_t at = std::min(sample.size() - 1, static_cast<size_t>(std::floor(appearance().strain_percentile / 100 *
                                                                               static_cast<double>(sample.size()))));
  std::nth_element(sample.begin(), sample.begin() + static_cast<long>(at), sample.end());
  return sample[at];
}

double strain_scale(const std::vector<double>& values) {
  StrainScaleSampler sampler(values.size());
  sampler.add(values);
  return sampler.scale();
}

}  // namespace weft::render
