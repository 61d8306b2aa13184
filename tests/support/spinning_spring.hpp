#pragma once
// The stiff spinning spring of the midpoint tests (a spring that turns within each step, which
// the step's start Jacobian does not see) and the mechanical energy of a spring system.
#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

namespace weft::test {

/// Kinetic plus elastic plus gravitational energy.
inline double mechanical_energy(SpringSystem& sys, const State& s) {
  Evaluation e;
  sys.evaluate(s.x, s.v, false, e);
  double kinetic = 0;
  for (int i = 0; i < sys.num_nodes(); ++i) kinetic += 0.5 * sys.node_mass()[i] * node(s.v, i).squaredNorm();
  return kinetic + e.elastic_energy + e.gravity_energy;
}

/// One 1 kg mass on a spring of rest length 1 m and stiffness k to the origin, going round
/// it at `speed` (m/s) on the circle where the spring holds it.
inline State spinning_spring_state(double k, double speed) {
  State s;
  s.x = Vec3(1.0 + speed * speed / k, 0, 0);
  s.v = Vec3(0, speed, 0);
  return s;
}

}  // namespace weft::test
