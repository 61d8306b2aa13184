#include "system/system.hpp"

namespace weft {

void System::assemble_step(const VecX& x, const VecX& v, const VecX& w, StepAssembly& out) {
  Evaluation& e = out.scratch;
  if (e.stiffness.pattern != &pattern()) prepare(e);
  evaluate(x, v, true, e);
  out.force = e.force;
  out.elastic_energy = e.elastic_energy;
  out.gravity_energy = e.gravity_energy;
  out.viscous_power = e.viscous_power;
  if (out.matrix.pattern != &pattern()) out.matrix.reset(pattern());
  const size_t count = 9 * out.matrix.block.size();
  double* a = out.matrix.block.front().data();
  const double* d = e.damping.block.front().data();
  const double* k = e.stiffness.block.front().data();
  for (size_t q = 0; q < count; ++q) a[q] = -out.cd * d[q] - out.ck * k[q];
  e.stiffness.multiply(w, out.stiffness_times_w);
}

void System::potential_energy(const VecX& x, double& elastic, double& gravity) {
  Evaluation e;
  evaluate(x, VecX::Zero(x.size()), false, e);
  elastic = e.elastic_energy;
  gravity = e.gravity_energy;
}

double System::viscous_power(const VecX& x, const VecX& v) {
  Evaluation e;
  prepare(e);
  evaluate(x, v, false, e);
  return e.viscous_power;
}

}  // namespace weft
