#pragma once
// Panel outlines for the mesher's tests and benchmark: polygons and closed curves sampled at
// about a given spacing, as the pattern reader hands them over.
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "mesh/panel_mesher.hpp"

namespace weft::test {

constexpr double kPanelPi = 3.14159265358979323846;

/// The closed polygon through `corners`, each side cut into round(length / spacing) pieces.
inline std::vector<Vec2> sampled_polygon(const std::vector<Vec2>& corners, double spacing) {
  std::vector<Vec2> points;
  for (size_t i = 0; i < corners.size(); ++i) {
    const Vec2& a = corners[i];
    const Vec2& b = corners[(i + 1) % corners.size()];
    const int pieces = std::max(1, static_cast<int>(std::lround((b - a).norm() / spacing)));
    for (int k = 0; k < pieces; ++k)
      points.push_back(a + (b - a) * (static_cast<double>(k) / pieces));
  }
  return points;
}

/// The closed curve r(phi) around `centre` (counter-clockwise), resampled at about equal arc
/// lengths near `spacing`.
template <class Radius>
std::vector<Vec2> sampled_closed_curve(const Vec2& centre, Radius radius, double spacing) {
  const int fine = 4000;
  std::vector<Vec2> curve(fine + 1);
  std::vector<double> arc(fine + 1, 0.0);
  for (int i = 0; i <= fine; ++i) {
    const double phi = 2 * kPanelPi * i / fine;
    curve[i] = centre + radius(phi) * Vec2(std::cos(phi), std::sin(phi));
    if (i > 0) arc[i] = arc[i - 1] + (curve[i] - curve[i - 1]).norm();
  }
  const int pieces = std::max(3, static_cast<int>(std::lround(arc[fine] / spacing)));
  std::vector<Vec2> points;
  int j = 0;
  for (int k = 0; k < pieces; ++k) {
    const double s = arc[fine] * k / pieces;
    while (arc[j + 1] < s) ++j;
    const double w = (s - arc[j]) / (arc[j + 1] - arc[j]);
    points.push_back((1 - w) * curve[j] + w * curve[j + 1]);
  }
  return points;
}

inline std::vector<Vec2> sampled_circle(const Vec2& centre, double radius, double spacing) {
  return sampled_closed_curve(
      centre, [radius](double) { return radius; }, spacing);
}

/// A random star-shaped curve: mean radius `radius`, five random harmonics whose amplitudes
/// sum to at most 0.45 of it (so r > 0 and the curve stays simple).
inline std::vector<Vec2> random_star(std::mt19937& rng, double radius, double spacing) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::array<double, 5> amplitude, phase;
  double total = 0;
  for (int k = 0; k < 5; ++k) {
    amplitude[k] = unit(rng) / (k + 1);
    phase[k] = 2 * kPanelPi * unit(rng);
    total += amplitude[k];
  }
  for (double& a : amplitude) a *= 0.45 / total;
  return sampled_closed_curve(
      Vec2::Zero(),
      [&](double phi) {
        double r = 1;
        for (int k = 0; k < 5; ++k) r += amplitude[k] * std::sin((k + 2) * phi + phase[k]);
        return radius * r;
      },
      spacing);
}

inline std::vector<Vec2> reversed(std::vector<Vec2> ring) {
  std::reverse(ring.begin(), ring.end());
  return ring;
}

/// The corners of a comb, counter-clockwise: a spine 0.05 m tall with `teeth` teeth 3 spacings
/// wide, 3 spacings apart and 0.12 m long.
inline std::vector<Vec2> comb_corners(int teeth, double spacing) {
  const double tooth = 3 * spacing, height = 0.12, spine = 0.05;
  std::vector<Vec2> c{{0, 0}, {(2 * teeth - 1) * tooth, 0}};
  for (int k = teeth - 1; k >= 0; --k) {
    const double x0 = 2 * k * tooth, x1 = x0 + tooth;
    c.push_back({x1, spine + height});
    c.push_back({x0, spine + height});
    if (k > 0) {
      c.push_back({x0, spine});
      c.push_back({x0 - tooth, spine});
    }
  }
  return c;
}

}  // namespace weft::test
