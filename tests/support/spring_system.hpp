#pragma once
// Small mechanical systems built from springs, for integrator tests: the integrators see
// them exactly as they see cloth.
#include <vector>

#include "elements/spring.hpp"
#include "system/system.hpp"

namespace weft::test {

struct Spring {
  int a, b;             ///< node indices; b = -1 ties a to the fixed point `anchor`
  double stiffness, rest_length, viscosity;
  Vec3 anchor = Vec3::Zero();
};

class SpringSystem : public System {
 public:
  SpringSystem(VecX mass, std::vector<Spring> springs, Vec3 gravity = Vec3::Zero())
      : mass_(std::move(mass)), springs_(std::move(springs)), gravity_(gravity) {
    const int n = static_cast<int>(mass_.size());
    pinned_.assign(n, 0);
    std::vector<std::pair<int, int>> pairs;
    for (const auto& s : springs_)
      if (s.b >= 0) pairs.emplace_back(s.a, s.b);
    pattern_ = BlockPattern(n, pairs);
  }
  int num_nodes() const override { return static_cast<int>(mass_.size()); }
  const VecX& node_mass() const override { return mass_; }
  const std::vector<char>& pinned() const override { return pinned_; }
  std::vector<char>& pinned() { return pinned_; }
  const BlockPattern& pattern() const override { return pattern_; }
  void evaluate(const VecX& x, const VecX& v, bool jacobians, Evaluation& out) override {
    if (out.force.size() != x.size() || out.stiffness.pattern != &pattern_) prepare(out);
    out.force.setZero();
    out.stiffness.set_zero();
    out.damping.set_zero();
    out.elastic_energy = out.gravity_energy = out.viscous_power = 0;
    for (int i = 0; i < num_nodes(); ++i) {
      node(out.force, i) += mass_[i] * gravity_;
      out.gravity_energy -= mass_[i] * gravity_.dot(node(x, i));
    }
    for (const auto& s : springs_) {
      const Vec3 xb = s.b >= 0 ? Vec3(node(x, s.b)) : s.anchor;
      const Vec3 vb = s.b >= 0 ? Vec3(node(v, s.b)) : Vec3::Zero();
      SpringResult r;
      evaluate_spring(s.stiffness, s.rest_length, s.viscosity, node(x, s.a), xb, node(v, s.a), vb, true, r);
      out.elastic_energy += r.energy;
      out.viscous_power += r.viscous_power;
      node(out.force, s.a) += r.force;
      if (s.b >= 0) node(out.force, s.b) -= r.force;
      if (!jacobians) continue;
      const auto add = [&](int i, int j, const Mat3& K, const Mat3& D) {
        const int slot = pattern_.slot(i, j);
        out.stiffness.block[slot] += K;
        out.damping.block[slot] += D;
      };
      add(s.a, s.a, r.stiffness, r.damping);
      if (s.b >= 0) {
        add(s.b, s.b, r.stiffness, r.damping);
        add(s.a, s.b, -r.stiffness, -r.damping);
        add(s.b, s.a, -r.stiffness, -r.damping);
      }
    }
  }

 private:
  VecX mass_;
  std::vector<Spring> springs_;
  Vec3 gravity_;
  std::vector<char> pinned_;
  BlockPattern pattern_;
};

/// One mass m on a zero-rest-length spring k with viscosity l to the origin: m p'' = -(k p + l p').
inline SpringSystem one_spring(double m, double k, double l) {
  return SpringSystem(VecX::Constant(1, m), {Spring{0, -1, k, 0.0, l}});
}

}  // namespace weft::test
