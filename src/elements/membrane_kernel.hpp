#pragma once
// The membrane element's arithmetic (docs/method.md 5), written once for every path that runs it:
// evaluate_membrane (one triangle, elements/membrane.cpp), the step assembly one triangle at
// a time and four at a time, and the viscous power over a step (system/cloth.cpp). Those
// callers only gather a triangle's vertices and scatter its results.
//
// The number type T is double, or Double4: four doubles, one triangle per lane (a GCC/Clang
// vector; arithmetic with a scalar operand applies it to every lane). The expressions are
// the same for both, element-wise in a fixed order, so a triangle gets the same values in
// either. Every function is always inlined, so that it is compiled for the instruction set
// of the kernel that calls it (linalg/dispatch.hpp).
//
// Notation: U = sum_k r_u,k x_k and V = sum_k r_v,k x_k are the deformation gradient's
// columns, Ud and Vd their rates; Green strains e_uu = (U.U - 1)/2, e_vv = (V.V - 1)/2,
// e_uv = U.V; strain rates (U.Ud, V.Vd, U.Vd + V.Ud); A the rest area.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "weft/material.hpp"

#define WEFT_ALWAYS_INLINE inline __attribute__((always_inline))

namespace weft {

typedef double Double4 __attribute__((vector_size(32)));

/// project_positive_2x2 for a matrix that is not positive semi-definite.
void project_indefinite_2x2(double& a, double& b, double& c);

/// Replaces the symmetric 2x2 matrix [[a, c], [c, b]] by its positive semi-definite part.
inline void project_positive_2x2(double& a, double& b, double& c) {
  if (a >= 0 && b >= 0 && a * b >= c * c) return;
  project_indefinite_2x2(a, b, c);
}

namespace membrane {

template <class T>
WEFT_ALWAYS_INLINE T dot3(const T* a, const T* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/// A value per mode: weft (uu), warp (vv), shear (uv).
template <class T>
struct Modes {
  T uu, vv, uv;
};

/// U = sum_k r_u,k y_k and V = sum_k r_v,k y_k of a vertex field y, `y(k, c)` giving
/// component c of vertex k (positions give the deformation gradient, velocities its rate, a
/// direction w its change along w).
template <class T, class Field>
WEFT_ALWAYS_INLINE void gradient(const T* ru, const T* rv, const Field& y, T* U, T* V) {
  for (int c = 0; c < 3; ++c) {
    const T y0 = y(0, c), y1 = y(1, c), y2 = y(2, c);
    U[c] = ru[0] * y0 + ru[1] * y1 + ru[2] * y2;
    V[c] = rv[0] * y0 + rv[1] * y1 + rv[2] * y2;
  }
}

template <class T>
WEFT_ALWAYS_INLINE Modes<T> green_strain(const T* U, const T* V) {
  return {0.5 * (dot3(U, U) - 1.0), 0.5 * (dot3(V, V) - 1.0), dot3(U, V)};
}

/// The strains' rates of change, U.Ud, V.Vd, U.Vd + V.Ud (the same sums along a direction
/// dU, dV give the strains' change along it).
template <class T>
WEFT_ALWAYS_INLINE Modes<T> strain_rate(const T* U, const T* V, const T* Ud, const T* Vd) {
  return {dot3(U, Ud), dot3(V, Vd), dot3(U, Vd) + dot3(V, Ud)};
}

/// A number of type M as a T: the same double, or M broadcast to every lane.
template <class T, class M>
WEFT_ALWAYS_INLINE T as(const M& m) {
  if constexpr (std::is_same_v<T, M>) return m;
  else return T{} + m;
}

/// The material's curves with every curve linear: a modulus per mode, the weft-warp
/// coupling C, and the tangents as the step's stiffness uses them (clamped at 0, C within
/// +-sqrt(t_uu t_vv)). M is double (one material for every lane) or the lanes' type.
template <class M>
struct LinearCurves {
  M weft, warp, shear, coupling;
  M tangent_uu, tangent_vv, tangent_uv, tangent_coupling;
  /// A material's linear curves (their moduli; the caller checks they are linear).
  static LinearCurves of(const Material& m) {
    LinearCurves c;
    c.weft = m.weft.modulus();
    c.warp = m.warp.modulus();
    c.shear = m.shear.modulus();
    c.coupling = m.coupling_modulus();
    c.tangent_uu = std::max(c.weft, 0.0);
    c.tangent_vv = std::max(c.warp, 0.0);
    c.tangent_uv = std::max(c.shear, 0.0);
    const double cmax = std::sqrt(c.tangent_uu * c.tangent_vv);
    c.tangent_coupling = std::clamp(c.coupling, -cmax, cmax);
    return c;
  }
  template <class T>
  WEFT_ALWAYS_INLINE Modes<T> stress(const Modes<T>& e) const {
    return {weft * e.uu + coupling * e.vv, warp * e.vv + coupling * e.uu, shear * e.uv};
  }
  template <class T>
  WEFT_ALWAYS_INLINE T energy(const Modes<T>& e) const {
    return 0.5 * weft * e.uu * e.uu + 0.5 * warp * e.vv * e.vv + 0.5 * shear * e.uv * e.uv +
           coupling * e.uu * e.vv;
  }
  /// The clamped tangents and coupling (semi-definite stiffness).
  template <class T>
  WEFT_ALWAYS_INLINE void definite_tangents(const Modes<T>&, Modes<T>& t, T& tc) const {
    t = {as<T>(tangent_uu), as<T>(tangent_vv), as<T>(tangent_uv)};
    tc = as<T>(tangent_coupling);
  }
};

/// A material's curves of any shape (one triangle at a time).
struct MaterialCurves {
  const Material& m;
  double coupling;
  explicit MaterialCurves(const Material& material) : m(material), coupling(material.coupling_modulus()) {}
  WEFT_ALWAYS_INLINE Modes<double> stress(const Modes<double>& e) const {
    return {m.weft.stress(e.uu) + coupling * e.vv, m.warp.stress(e.vv) + coupling * e.uu, m.shear.stress(e.uv)};
  }
  WEFT_ALWAYS_INLINE double energy(const Modes<double>& e) const {
    return m.weft.energy(e.uu) + m.warp.energy(e.vv) + m.shear.energy(e.uv) + coupling * e.uu * e.vv;
  }
  /// The exact tangents d s / d e (diagonal) and the coupling C.
  WEFT_ALWAYS_INLINE void tangents(const Modes<double>& e, Modes<double>& t, double& tc) const {
    t = {m.weft.tangent(e.uu), m.warp.tangent(e.vv), m.shear.tangent(e.uv)};
    tc = coupling;
  }
  WEFT_ALWAYS_INLINE void definite_tangents(const Modes<double>& e, Modes<double>& t, double& tc) const {
    tangents(e, t, tc);
    t = {std::max(t.uu, 0.0), std::max(t.vv, 0.0), std::max(t.uv, 0.0)};
    const double cmax = std::sqrt(t.uu * t.vv);
    tc = std::clamp(tc, -cmax, cmax);
  }
};

/// A triangle's elastic and viscous state: strains, elastic stresses, the force's
/// coefficients (the force on vertex i is -(r_u,i (fu U + fs V) + r_v,i (fs U + fv V))),
/// elastic energy and viscous power.
template <class T>
struct Forces {
  Modes<T> strain, stress;
  T fu, fv, fs;
  T energy, viscous_power;
};

/// The viscous power -A sum_m eta_m rate_m^2 (eta_m rate_m the viscous stress of docs/method.md 5).
template <class T>
WEFT_ALWAYS_INLINE T viscous_power(const T& area, const Modes<T>& eta, const Modes<T>& rate) {
  const T sv0 = eta.uu * rate.uu, sv1 = eta.vv * rate.vv, sv2 = eta.uv * rate.uv;
  return -area * (sv0 * rate.uu + sv1 * rate.vv + sv2 * rate.uv);
}

/// The elastic energy A W(e) of a triangle of rest area A at Green strain e.
template <class T, class Curves>
WEFT_ALWAYS_INLINE T strain_energy(const Curves& curves, const T& area, const Modes<T>& strain) {
  return area * curves.energy(strain);
}

template <class T, class Curves>
WEFT_ALWAYS_INLINE void forces(const Curves& curves, const T& area, const Modes<T>& eta, const T* U, const T* V,
                               const T* Ud, const T* Vd, Forces<T>& out) {
  out.strain = green_strain(U, V);
  out.stress = curves.stress(out.strain);
  out.energy = strain_energy(curves, area, out.strain);
  const Modes<T> rate = strain_rate(U, V, Ud, Vd);
  out.viscous_power = viscous_power(area, eta, rate);
  out.fu = area * (out.stress.uu + eta.uu * rate.uu);
  out.fv = area * (out.stress.vv + eta.vv * rate.vv);
  out.fs = area * (out.stress.uv + eta.uv * rate.uv);
}

/// Force on each vertex, f_i = -(r_u,i (fu U + fs V) + r_v,i (fs U + fv V)), handed to
/// `add(i, c, value)` as minus the value.
template <class T, class Add>
WEFT_ALWAYS_INLINE void scatter_force(const Forces<T>& f, const T* ru, const T* rv, const T* U, const T* V,
                                      const Add& add) {
  for (int c = 0; c < 3; ++c) {
    const T force_u = f.fu * U[c] + f.fs * V[c], force_v = f.fs * U[c] + f.fv * V[c];
    for (int i = 0; i < 3; ++i) add(i, c, ru[i] * force_u + rv[i] * force_v);
  }
}

/// The moduli of the stiffness: tangents (weft, warp, shear), the weft-warp coupling and the
/// geometric stress matrix [[s00, s01], [s01, s11]].
template <class T>
struct Stiffness {
  Modes<T> tangent;
  T coupling, s00, s11, s01;
};

/// [[a, c], [c, b]] replaced by its positive semi-definite part.
WEFT_ALWAYS_INLINE void project_stress(double& a, double& b, double& c) { project_positive_2x2(a, b, c); }

/// The same for four lanes: project_indefinite_2x2's expressions, in the lanes that need it.
WEFT_ALWAYS_INLINE void project_stress(Double4& a, Double4& b, Double4& c) {
  const auto keep = (a >= 0) & (b >= 0) & (a * b >= c * c);
  if (keep[0] & keep[1] & keep[2] & keep[3]) return;
  const Double4 zero = {0, 0, 0, 0};
  const Double4 h = 0.5 * (a - b), mean = 0.5 * (a + b), q = h * h + c * c;
  const Double4 r = {std::sqrt(q[0]), std::sqrt(q[1]), std::sqrt(q[2]), std::sqrt(q[3])};
  const Double4 l1 = mean + r;
  const auto degenerate = (l1 <= 0) | ~(r > 0);
  const auto h_positive = h >= 0;
  const Double4 large = h_positive ? h + r : r - h;
  const Double4 small = c * c / large;
  const Double4 scale = l1 / (2 * r);
  const Double4 positive_l1 = l1 < 0 ? zero : l1;  // std::max(l1, 0.0)
  const Double4 pa = degenerate ? positive_l1 : scale * (h_positive ? large : small);
  const Double4 pb = degenerate ? positive_l1 : scale * (h_positive ? small : large);
  const Double4 pc = degenerate ? zero : scale * c;
  a = keep ? a : pa;
  b = keep ? b : pb;
  c = keep ? c : pc;
}

/// The semi-definite stiffness's moduli: clamped tangents and the stress matrix projected
/// (compressed membranes otherwise make the step matrix indefinite; docs/method.md 1).
template <class T, class Curves>
WEFT_ALWAYS_INLINE Stiffness<T> definite_stiffness(const Curves& curves, const Forces<T>& f) {
  Stiffness<T> k;
  curves.definite_tangents(f.strain, k.tangent, k.coupling);
  k.s00 = f.stress.uu;
  k.s11 = f.stress.vv;
  k.s01 = f.stress.uv;
  project_stress(k.s00, k.s11, k.s01);
  return k;
}

/// (K w)_i, the force's derivative along w (dU, dV its gradient's change), handed to
/// `add(i, c, value)` as minus the value: -A (r_u,i (du U + ds V + gu) + r_v,i (ds U + dv V +
/// gv)) with the strains' changes through the tangents (du, dv, ds) and the stress matrix's
/// terms gu = s00 dU + s01 dV, gv = s11 dV + s01 dU.
template <class T, class Add>
WEFT_ALWAYS_INLINE void scatter_stiffness_times(const Stiffness<T>& k, const T& area, const T* ru, const T* rv,
                                                const T* U, const T* V, const T* dU, const T* dV, const Add& add) {
  const Modes<T> d = strain_rate(U, V, dU, dV);
  const T du = k.tangent.uu * d.uu + k.coupling * d.vv, dv = k.tangent.vv * d.vv + k.coupling * d.uu;
  const T ds = k.tangent.uv * d.uv;
  for (int c = 0; c < 3; ++c) {
    const T kw_u = area * (du * U[c] + ds * V[c] + k.s00 * dU[c] + k.s01 * dV[c]);
    const T kw_v = area * (ds * U[c] + dv * V[c] + k.s11 * dV[c] + k.s01 * dU[c]);
    for (int i = 0; i < 3; ++i) add(i, c, ru[i] * kw_u + rv[i] * kw_v);
  }
}

/// The step matrix's blocks -(ck K + cd D) of a triangle, as four 3x3 matrices Muu, Muv, Mvu,
/// Mvv (m[0..3], column-major: entry (r, c) at 3 c + r): block (i, j) is
///   r_u,i r_u,j Muu + r_u,i r_v,j Muv + r_v,i r_u,j Mvu + r_v,i r_v,j Mvv,
/// and with T_m = A (ck t_m + cd eta_m), Tc = A ck C, S = A ck [[s00, s01], [s01, s11]]:
///   Muu = Tu UU^T + Ts VV^T + S00 I,   Mvv = Ts UU^T + Tv VV^T + S11 I,
///   Muv = Tc UV^T + Ts VU^T + S01 I,   Mvu = Ts UV^T + Tc VU^T + S01 I.
/// (ck = 1, cd = 0 gives -K; ck = 0, cd = 1 gives -D.)
template <class T>
WEFT_ALWAYS_INLINE void step_matrices(const Stiffness<T>& k, const Modes<T>& eta, const T& area, double ck,
                                      double cd, const T* U, const T* V, T m[4][9]) {
  const T Tu = area * (ck * k.tangent.uu + cd * eta.uu), Tv = area * (ck * k.tangent.vv + cd * eta.vv);
  const T Ts = area * (ck * k.tangent.uv + cd * eta.uv), Tc = area * (ck * k.coupling);
  const T S00 = area * ck * k.s00, S11 = area * ck * k.s11, S01 = area * ck * k.s01;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) {
      const T uu = U[r] * U[c], vv = V[r] * V[c], uv = U[r] * V[c], vu = V[r] * U[c];
      T muu = Tu * uu + Ts * vv, mvv = Ts * uu + Tv * vv, muv = Tc * uv + Ts * vu, mvu = Ts * uv + Tc * vu;
      if (r == c) {
        muu += S00;
        mvv += S11;
        muv += S01;
        mvu += S01;
      }
      const int e = 3 * c + r;
      m[0][e] = muu;
      m[1][e] = muv;
      m[2][e] = mvu;
      m[3][e] = mvv;
    }
}

}  // namespace membrane
}  // namespace weft
