// Symmetric block SOR preconditioned CG with Eisenstat's trick (linalg/pcg.hpp, kSsor) and
// the operators it is built on (linalg/ssor.hpp), against dense algebra.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "linalg/pcg.hpp"
#include "linalg/ssor.hpp"
#include "support/cloth_step_problem.hpp"
#include "support/random_vectors.hpp"

namespace weft {
namespace {

using test::random_vector;
using test::zero_fixed;

// The step matrix on the free nodes as a dense matrix with the nodes in the solves' order
// (pinned rows and columns replaced by the identity), split into its block-diagonal,
// strictly lower and strictly upper parts.
struct DenseSplit {
  MatX A, diag, lower, upper;
};

DenseSplit split(const BlockMatrix& M, const std::vector<char>& fixed,
                 const std::vector<int>& order) {
  const int n = M.pattern->num_nodes();
  const MatX full = M.to_dense();
  DenseSplit s;
  s.A = MatX::Zero(3 * n, 3 * n);
  for (int p = 0; p < n; ++p)
    for (int q = 0; q < n; ++q) {
      const int i = order[p], j = order[q];
      if (fixed[i] || fixed[j]) continue;
      s.A.block<3, 3>(3 * p, 3 * q) = full.block<3, 3>(3 * i, 3 * j);
    }
  for (int p = 0; p < n; ++p)
    if (fixed[order[p]]) s.A.block<3, 3>(3 * p, 3 * p).setIdentity();
  s.diag = s.lower = s.upper = MatX::Zero(3 * n, 3 * n);
  for (int p = 0; p < n; ++p)
    for (int q = 0; q < n; ++q) {
      MatX& part = q < p ? s.lower : (q > p ? s.upper : s.diag);
      part.block<3, 3>(3 * p, 3 * q) = s.A.block<3, 3>(3 * p, 3 * q);
    }
  return s;
}

// The operator's vector by position: 3 doubles per node in the solves' order.
template <class T>
VecX by_position(const SsorOperatorT<T>& S, const typename SsorOperatorT<T>::Vector& g) {
  const int n = S.num_nodes();
  VecX v(3 * n);
  for (int p = 0; p < n; ++p)
    for (int c = 0; c < 3; ++c) v(3 * p + c) = g(S.index(p, c));
  return v;
}

// Sum of |g| over the lanes that hold no node (past the end of the last stretch).
template <class T>
double absent_lanes(const SsorOperatorT<T>& S, const typename SsorOperatorT<T>::Vector& g) {
  std::vector<char> used(g.size(), 0);
  for (int p = 0; p < S.num_nodes(); ++p)
    for (int c = 0; c < 3; ++c) used[S.index(p, c)] = 1;
  double s = 0;
  for (long k = 0; k < g.size(); ++k)
    if (!used[k]) s += std::abs(g(k));
  return s;
}

// The lane-major slot (kLanes * group + lane) of position p.
long slot_of(const SsorOperator& S, int p) {
  const long k = S.index(p, 0);
  return k / 12 * SsorOperator::kLanes + k % 12;
}

// The order takes the g-th node of each of four stretches of the numbering in turn, in
// groups; the stretch is at least a quarter of the nodes, and on a 9x9 cloth no two nodes
// of a group are coupled, so no group is solved lane by lane.
TEST(Ssor, OrderTakesStretchesOfTheNumberingSideBySide) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.0, p);
  SsorOperator S;
  S.assign(p.matrix(), p.pinned(), 1.0);
  const auto& order = S.order();
  ASSERT_EQ(order.size(), 81u);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < 81; ++i) EXPECT_EQ(sorted[i], i);
  const int stretch = S.stretch();
  EXPECT_GE(SsorOperator::kLanes * stretch, 81);
  EXPECT_EQ(S.vector_size(), 12L * stretch);
  for (int q = 0; q < 81; ++q) {
    const long slot = slot_of(S, q);
    EXPECT_EQ(order[q], slot % SsorOperator::kLanes * stretch + slot / SsorOperator::kLanes) << q;
    if (q > 0) EXPECT_GT(slot, slot_of(S, q - 1)) << "positions follow the groups";
    EXPECT_EQ(S.index(q, 1) - S.index(q, 0), 4) << q;
    EXPECT_EQ(S.index(q, 2) - S.index(q, 0), 8) << q;
  }
  EXPECT_EQ(S.num_sequential_groups(), 0);
}

// A base order is split into stretches the same way; one that is not a permutation is refused.
TEST(Ssor, OrderTakesStretchesOfTheBaseOrderSideBySide) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.0, p);
  std::vector<int> base(81);
  for (int i = 0; i < 81; ++i) base[i] = 80 - i;
  SsorOperator S, T;
  S.assign(p.matrix(), p.pinned(), 1.0);
  T.assign(p.matrix(), p.pinned(), 1.0, &base);
  for (int q = 0; q < 81; ++q) EXPECT_EQ(T.order()[q], base[S.order()[q]]) << q;
  base[3] = base[4];
  try {
    T.assign(p.matrix(), p.pinned(), 1.0, &base);
    ADD_FAILURE() << "a repeated node was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "SSOR node order is not a permutation of the 81 nodes");
  }
}

// (B + L) y = v and (B + L^T) y = v with B = D/omega, y = A x and y = s D x, against dense
// algebra in the solves' order; pinned nodes come out zero and so do the lanes past the last
// node. In double precision, on a 9x9 cloth every group is solved four lanes at once; on a
// 2x2 cloth whose two free nodes (coupled) come a stretch apart in the base order, they share
// a group, which is then solved lane by lane. In single precision (eight lanes) likewise, and
// on a 21x21 cloth. `tol`: relative error allowed.
template <class T>
void expect_operators_match_dense_on(const test::ClothStepProblem& p, const std::vector<char>& fixed,
                                     const std::vector<int>* base, bool sequential, double tol) {
  using Vector = typename SsorOperatorT<T>::Vector;
  const int nodes = p.matrix().pattern->num_nodes();
  const double omega = 1.3;
  SsorOperatorT<T> S;
  S.assign(p.matrix(), fixed, omega, base);
  EXPECT_EQ(S.num_sequential_groups() > 0, sequential);
  if (!sequential)
    EXPECT_GT(S.num_scalar(), 0) << "the hinge couplings are multiples of the identity";
  EXPECT_GT(S.num_whole(), 0);
  const DenseSplit d = split(p.matrix(), fixed, S.order());
  const MatX B = d.diag / omega;
  std::mt19937 rng(4);
  VecX v = random_vector(3 * nodes, rng);
  Vector v4, y4(S.vector_size()), u4(S.vector_size());
  S.pad(v, v4);  // zero on pinned nodes
  EXPECT_EQ(v4.size(), S.vector_size());
  const VecX vp = by_position(S, v4);
  S.solve_lower(v4.data(), y4.data());
  EXPECT_LE(((B + d.lower) * by_position(S, y4) - vp).norm(), tol * vp.norm());
  EXPECT_EQ(absent_lanes(S, y4), 0.0);
  const Vector t = random_vector(S.vector_size(), rng).template cast<T>(),
               q = random_vector(S.vector_size(), rng).template cast<T>();
  const double dot = S.solve_lower_dot(v4.data(), y4.data(), q.data(), t.data());
  const VecX qd = q.template cast<double>(), yt = (y4 + t).template cast<double>();
  EXPECT_NEAR(dot, qd.dot(yt), tol * qd.norm() * yt.norm());
  const double cp = 0.3, cu = 0.6;
  S.solve_upper(v4.data(), y4.data(), u4.data(), cp, cu);
  const VecX yp = by_position(S, y4);
  EXPECT_LE(((B + d.upper) * yp - vp).norm(), tol * vp.norm());
  EXPECT_LE((by_position(S, u4) - (cp * vp + cu * d.upper * yp)).norm(), tol * vp.norm());
  EXPECT_EQ(absent_lanes(S, y4) + absent_lanes(S, u4), 0.0);
  S.multiply(v4.data(), y4.data());
  VecX expected = d.A * vp;
  for (int k = 0; k < nodes; ++k)
    if (fixed[S.order()[k]]) expected.segment<3>(3 * k).setZero();
  EXPECT_LE((by_position(S, y4) - expected).norm(), tol * expected.norm());
  EXPECT_EQ(absent_lanes(S, y4), 0.0);
  S.diagonal_times(0.7, v4.data(), y4.data());
  EXPECT_LE((by_position(S, y4) - 0.7 * d.diag * vp).norm(), tol * vp.norm());
  // Back to node order.
  VecX back;
  S.unpad(v4, back);
  zero_fixed(fixed, v);
  const double rounding = std::is_same_v<T, double> ? 0.0 : 1e-7 * v.norm();
  EXPECT_LE((back - v).norm(), rounding);
}

template <class T>
void expect_operators_match_dense(int n, int pinned, bool sequential, double tol = 1e-12) {
  SCOPED_TRACE(std::to_string(n) + "x" + std::to_string(n));
  test::ClothStepProblem p;
  test::make_cloth_step_problem(n, 0.02, p);
  std::vector<char> fixed = p.pinned();
  if (pinned >= 0) fixed[pinned] = 1;
  std::vector<int> base;  // on the 2x2 cloth, the two free nodes a stretch apart
  if (n == 2) {
    std::vector<int> free_nodes, fixed_nodes;
    for (int i = 0; i < 4; ++i) (fixed[i] ? fixed_nodes : free_nodes).push_back(i);
    ASSERT_EQ(free_nodes.size(), 2u);
    base = {free_nodes[0], fixed_nodes[0], free_nodes[1], fixed_nodes[1]};
  }
  expect_operators_match_dense_on<T>(p, fixed, n == 2 ? &base : nullptr, sequential, tol);
}

// An n x n cloth, 1 m across, horizontal at 1 m height, whose cells are split along random
// diagonals and whose vertices are numbered in random order, as an OBJ file (texture
// coordinates = pattern in metres); pinned at the two corners of one edge. The lanes'
// coupling patterns no longer coincide, as on a garment's mesh.
Scene irregular_cloth_scene(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<int> number(n * n);  // grid node -> OBJ vertex
  std::iota(number.begin(), number.end(), 0);
  std::shuffle(number.begin(), number.end(), rng);
  std::vector<Vec2> uv(n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) uv[number[j * n + i]] = Vec2(double(i) / (n - 1), double(j) / (n - 1));
  const std::string path =
      (std::filesystem::temp_directory_path() / ("weft_irregular_" + std::to_string(seed) + ".obj")).string();
  std::ofstream out(path);
  for (const Vec2& p : uv) out << "v " << p.x() << " 1 " << p.y() << "\n";
  for (const Vec2& p : uv) out << "vt " << p.x() << " " << p.y() << "\n";
  const auto face = [&](int a, int b, int c) {
    out << "f";
    for (int k : {a, b, c}) out << " " << number[k] + 1 << "/" << number[k] + 1;
    out << "\n";
  };
  std::bernoulli_distribution flip(0.5);
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      if (flip(rng)) {
        face(a, b, d);
        face(a, d, c);
      } else {
        face(a, b, c);
        face(b, d, c);
      }
    }
  out.close();
  return test::cloth_step_scene_from_obj(n, path, {number[0], number[n - 1]});
}

TEST(Ssor, OperatorsMatchDense) {
  expect_operators_match_dense<double>(9, 40, false);
  expect_operators_match_dense<double>(2, -1, true);
}

// The same operators in single precision, eight lanes: the same algebra to float rounding.
TEST(Ssor, SinglePrecisionOperatorsMatchDense) {
  static_assert(SsorOperatorT<float>::kLanes == 8);
  expect_operators_match_dense<float>(21, 200, false, 2e-5);
  expect_operators_match_dense<float>(9, 40, false, 2e-5);
  expect_operators_match_dense<float>(2, -1, true, 2e-5);
}

// On a mesh with random diagonals and a scrambled numbering, in the order the solver uses
// (mesh/mesh.hpp banded_order): the same operators in both precisions, and single-precision
// SSOR-PCG reaches the tolerance on the true residual as double precision does.
TEST(Ssor, OperatorsMatchDenseOnAnIrregularMesh) {
  test::ClothStepProblem p;
  const Scene scene = irregular_cloth_scene(24, 11);
  test::make_cloth_step_problem(scene, 0.02, p);
  std::filesystem::remove(scene.cloth.obj_path);  // read when the simulation was built
  const std::vector<int>* order = p.sim->core().system().solver_order();
  ASSERT_NE(order, nullptr);
  expect_operators_match_dense_on<double>(p, p.pinned(), order, false, 1e-12);
  expect_operators_match_dense_on<float>(p, p.pinned(), order, false, 2e-5);
  VecX b = p.rhs;
  zero_fixed(p.pinned(), b);
  PcgSettings s;
  s.preconditioner = Preconditioner::kSsor;
  s.node_order = order;
  PcgWorkspace ws_double, ws_single;
  VecX x_double = p.guess, x_single = p.guess;
  ASSERT_TRUE(solve_pcg(p.matrix(), p.rhs, p.pinned(), s, x_double, ws_double).converged);
  s.ssor_single_precision = true;
  ASSERT_TRUE(solve_pcg(p.matrix(), p.rhs, p.pinned(), s, x_single, ws_single).converged);
  EXPECT_EQ(ws_single.ssor_single_fallbacks, 0);
  VecX res;
  p.matrix().multiply(x_single, res);
  res -= b;
  zero_fixed(p.pinned(), res);
  EXPECT_LE(res.norm(), s.relative_tolerance * b.norm());
  EXPECT_LE((x_single - x_double).norm(), 1e3 * s.relative_tolerance * x_double.norm());
}

// The product of the copy with a random vector against the dense product.
double relative_product_error(const SsorOperator& S, const BlockMatrix& A, const std::vector<char>& fixed,
                              std::mt19937& rng) {
  const int nodes = A.pattern->num_nodes();
  const DenseSplit d = split(A, fixed, S.order());
  VecX v = random_vector(3 * nodes, rng), v4, y4(S.vector_size());
  S.pad(v, v4);
  S.multiply(v4.data(), y4.data());
  VecX expected = d.A * by_position(S, v4);
  for (int q = 0; q < nodes; ++q)
    if (fixed[S.order()[q]]) expected.segment<3>(3 * q).setZero();
  return (by_position(S, y4) - expected).norm() / expected.norm();
}

// A block stored as a scalar (a hinge coupling) that stops being a multiple of the identity
// makes the copy lay itself out again: the product still equals the dense one.
TEST(Ssor, LayoutFollowsTheMatrix) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.pinned();
  SsorOperator S;
  S.assign(p.matrix(), fixed, 1.2);
  const long scalars = S.num_scalar();
  ASSERT_GT(scalars, 0);
  BlockMatrix A = p.matrix();
  ASSERT_TRUE(test::break_one_scalar_block(A, fixed));
  S.assign(A, fixed, 1.2);
  EXPECT_LT(S.num_scalar(), scalars)
      << "the block, its transpose and the other lanes of their entries";
  std::mt19937 rng(6);
  EXPECT_LE(relative_product_error(S, A, fixed, rng), 1e-12);
}

// The cloth marks the hinge couplings' blocks as constant slots of the step matrix; the copy
// reads them again only when the matrix's constant version changes, and the cloth's
// assembly changes it when ck or cd (the step size) do.
TEST(Ssor, ConstantBlocksAreReadAgainWhenTheirVersionChanges) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.pinned();
  ASSERT_NE(p.matrix().constant_slots, nullptr);
  SsorOperator S;
  S.assign(p.matrix(), fixed, 1.2);
  std::mt19937 rng(8);
  EXPECT_LE(relative_product_error(S, p.matrix(), fixed, rng), 1e-12);
  // A constant block doubled (still a multiple of the identity) without a new version: the
  // copy keeps the old value, so its product differs from the new matrix's.
  BlockMatrix A = p.matrix();
  const auto& rs = A.pattern->row_start();
  const auto& col = A.pattern->column();
  int changed = -1;
  for (int i = 0; i < A.pattern->num_nodes() && changed < 0; ++i)
    for (int s = rs[i]; s < rs[i + 1]; ++s)
      if ((*A.constant_slots)[s] && !fixed[i] && !fixed[col[s]]) {
        A.block[s] *= 2;
        A.block[A.pattern->slot(col[s], i)] *= 2;
        changed = s;
        break;
      }
  ASSERT_GE(changed, 0);
  S.assign(A, fixed, 1.2);
  EXPECT_GT(relative_product_error(S, A, fixed, rng), 1e-8) << "the copy read the constant block again";
  A.constants_changed();
  S.assign(A, fixed, 1.2);
  EXPECT_LE(relative_product_error(S, A, fixed, rng), 1e-12);
  // The cloth's assembly with another ck and cd gives a new version, and the copy follows.
  const long version = p.step.matrix.constant_version;
  State& st = p.sim->core().state();
  const VecX w = 0.005 * st.v;
  p.sim->core().system().assemble_step(st.x, st.v, w, p.step);
  EXPECT_EQ(p.step.matrix.constant_version, version) << "same ck and cd";
  S.assign(p.step.matrix, fixed, 1.2);
  p.step.ck *= 1.5;
  p.step.cd *= 1.2;
  p.sim->core().system().assemble_step(st.x, st.v, w, p.step);
  EXPECT_NE(p.step.matrix.constant_version, version);
  S.assign(p.step.matrix, fixed, 1.2);
  EXPECT_LE(relative_product_error(S, p.step.matrix, fixed, rng), 1e-12);
}

// A free node whose diagonal block is numerically singular gets the inverse of the block's
// diagonal in B^-1 (invert_spd_block's fallback), while the other lanes of its group keep
// their exact inverses: with v nonzero at one node only, y there is B^-1 v.
TEST(Ssor, SingularDiagonalBlockFallsBackToItsDiagonal) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.pinned();
  BlockMatrix A = p.matrix();
  const int node = 40;
  ASSERT_FALSE(fixed[node]);
  const Vec3 u(1.0, 2.0, -0.5);
  A.block[A.pattern->diagonal_slot(node)] = u * u.transpose();  // rank one: determinant 0
  const double omega = 1.2;
  SsorOperator S;
  S.assign(A, fixed, omega);
  int position = -1;
  for (int q = 0; q < S.num_nodes(); ++q)
    if (S.order()[q] == node) position = q;
  ASSERT_GE(position, 0);
  int neighbour = -1;  // a node of the same group
  for (int q = 0; q < S.num_nodes(); ++q)
    if (q != position && S.index(q, 0) / 12 == S.index(position, 0) / 12 && !fixed[S.order()[q]])
      neighbour = S.order()[q];
  ASSERT_GE(neighbour, 0);
  for (int probe : {node, neighbour}) {
    VecX v = VecX::Zero(3 * 81), v4, y4(S.vector_size());
    v.segment<3>(3 * probe) = Vec3(0.3, -1.0, 2.0);
    S.pad(v, v4);
    S.solve_lower(v4.data(), y4.data());
    VecX y;
    S.unpad(y4, y);
    const Mat3& d = A.block[A.pattern->diagonal_slot(probe)];
    const Mat3 inv = probe == node ? inverse_of_diagonal(d) : Mat3(d.inverse());
    const Vec3 expected = omega * inv * v.segment<3>(3 * probe);
    EXPECT_LE((y.segment<3>(3 * probe) - expected).norm(), 1e-12 * expected.norm()) << "node " << probe;
  }
}

// In exact arithmetic CG on the transformed system produces the same iterates as textbook
// PCG with the explicit SSOR preconditioner M^-1 = (B + U)^-1 B (B + L)^-1 (in the solves'
// order). After the same number of iterations from the same guess both must agree to
// rounding.
TEST(Ssor, EisenstatIteratesEqualExplicitPreconditioner) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(9, 0.02, p);
  const auto& fixed = p.pinned();
  const double omega = 1.4;
  SsorOperator S;
  S.assign(p.matrix(), fixed, omega);
  const DenseSplit d = split(p.matrix(), fixed, S.order());
  const MatX B = d.diag / omega;
  VecX b4;
  S.pad(p.rhs, b4);
  const VecX b = by_position(S, b4);
  // Block (not scalar) triangular factors: solved densely.
  const Eigen::PartialPivLU<MatX> BL(B + d.lower), BU(B + d.upper);
  auto precondition = [&](const VecX& r) -> VecX { return BU.solve(B * BL.solve(r)); };
  for (int k : {1, 3, 6}) {
    VecX x_ref = VecX::Zero(b.size());
    VecX r = b, z = precondition(r), q = z;
    double rz = r.dot(z);
    for (int it = 0; it < k; ++it) {
      const VecX Aq = d.A * q;
      const double a = rz / q.dot(Aq);
      x_ref += a * q;
      r -= a * Aq;
      z = precondition(r);
      const double rz_new = r.dot(z);
      q = z + rz_new / rz * q;
      rz = rz_new;
    }
    PcgSettings s;
    s.preconditioner = Preconditioner::kSsor;
    s.ssor_omega = omega;
    s.relative_tolerance = 1e-300;
    s.max_iterations = k;
    PcgWorkspace ws;
    VecX x = VecX::Zero(b.size());
    const PcgResult res = solve_pcg(p.matrix(), p.rhs, fixed, s, x, ws);
    EXPECT_EQ(res.iterations, k);
    VecX x4;
    S.pad(x, x4);
    EXPECT_LE((by_position(S, x4) - x_ref).norm(), 1e-10 * x_ref.norm()) << k << " iterations";
  }
}

// The reported residual is the true one: |b - A x| <= tol |b| recomputed from the full
// matrix, pinned nodes held at zero, and a new fixed set on the same workspace is honoured.
// The SSOR preconditioner is much stronger than block-Jacobi on the cloth (its iteration
// count grows like the square root of block-Jacobi's for these grid-ordered meshes), so it
// must need clearly fewer iterations.
TEST(Ssor, SolvesToTheTrueResidualInFewerIterationsThanBlockJacobi) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  std::vector<char> fixed = p.pinned();
  PcgWorkspace ws, ws_bj;
  for (int round = 0; round < 2; ++round) {
    if (round == 1) fixed[500] = 1;
    for (double omega : {1.0, 1.5}) {
      PcgSettings s;
      s.relative_tolerance = 1e-8;
      VecX x_bj = p.guess;
      const PcgResult bj = solve_pcg(A, p.rhs, fixed, s, x_bj, ws_bj);
      s.preconditioner = Preconditioner::kSsor;
      s.ssor_omega = omega;
      VecX x = p.guess;
      const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
      ASSERT_TRUE(bj.converged);
      ASSERT_TRUE(r.converged);
      EXPECT_LT(2 * r.iterations, bj.iterations) << "omega " << omega;
      VecX b = p.rhs, res;
      zero_fixed(fixed, b);
      for (size_t i = 0; i < fixed.size(); ++i)
        if (fixed[i]) EXPECT_EQ(x.segment<3>(3 * i).norm(), 0.0) << "node " << i;
      A.multiply(x, res);
      res -= b;
      zero_fixed(fixed, res);
      EXPECT_LE(res.norm(), 1e-8 * b.norm());
      EXPECT_NEAR(r.relative_residual, res.norm() / b.norm(), 1e-12);
      EXPECT_LE((x - x_bj).norm(), 1e-5 * x_bj.norm());
    }
  }
}

// In single precision the iterations run on float copies, but the solution and the residual
// the solve stops on are in double precision: the same tolerance holds on the true residual,
// also far below what single precision resolves (1e-12 needs restarts from the true
// residual), and the solution is the double-precision solve's to that tolerance.
TEST(Ssor, SinglePrecisionSolvesToTheTrueResidual) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  std::vector<char> fixed = p.pinned();
  fixed[500] = 1;
  VecX b = p.rhs;
  zero_fixed(fixed, b);
  for (double tol : {1e-6, 1e-12}) {
    PcgSettings s;
    s.relative_tolerance = tol;
    s.preconditioner = Preconditioner::kSsor;
    s.node_order = p.sim->core().system().solver_order();
    PcgWorkspace ws, ws_double;
    VecX x_double = p.guess;
    const PcgResult d = solve_pcg(A, p.rhs, fixed, s, x_double, ws_double);
    s.ssor_single_precision = true;
    VecX x = p.guess;
    const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
    ASSERT_TRUE(d.converged);
    ASSERT_TRUE(r.converged) << "tolerance " << tol;
    EXPECT_EQ(ws.ssor_single_fallbacks, 0) << "every restart at least halved the residual";
    EXPECT_EQ(x.segment<3>(3 * 500).norm(), 0.0);
    VecX res;
    A.multiply(x, res);
    res -= b;
    zero_fixed(fixed, res);
    EXPECT_LE(res.norm(), tol * b.norm()) << "tolerance " << tol;
    EXPECT_NEAR(r.relative_residual, res.norm() / b.norm(), 1e-3 * tol);
    // Both solutions are within the tolerance's reach of the exact one.
    EXPECT_LE((x - x_double).norm(), 1e3 * tol * x_double.norm()) << "tolerance " << tol;
    if (tol < 1e-8) EXPECT_GT(r.iterations, d.iterations) << "restarts cost iterations below float precision";
  }
}

// A tolerance below double precision's rounding is out of reach: the single-precision restarts
// stop halving the true residual, and the solve goes on in double precision with the
// iterations left, so the cap holds for the solve as a whole. It reports the true residual it
// ended on (recomputed here in another summation order, so equal to within the products'
// rounding, a few eps |A| |x|) and that residual is at double precision's level.
TEST(Ssor, SinglePrecisionFallsBackToDoubleWithinTheIterationCap) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  const std::vector<char>& fixed = p.pinned();
  VecX b = p.rhs;
  zero_fixed(fixed, b);
  PcgSettings s;
  s.relative_tolerance = 1e-17;
  s.max_iterations = 150;
  s.preconditioner = Preconditioner::kSsor;
  s.node_order = p.sim->core().system().solver_order();
  s.ssor_single_precision = true;
  PcgWorkspace ws;
  VecX x = p.guess;
  const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(ws.ssor_single_fallbacks, 1);
  EXPECT_LE(r.iterations, s.max_iterations);
  EXPECT_GT(r.iterations, 0);
  VecX res, abs_product;
  A.multiply(x, res);
  res -= b;
  zero_fixed(fixed, res);
  BlockMatrix abs_A = A;
  for (Mat3& m : abs_A.block) m = m.cwiseAbs();
  abs_A.multiply(x.cwiseAbs(), abs_product);
  zero_fixed(fixed, abs_product);
  const double rounding = 16 * std::numeric_limits<double>::epsilon() * abs_product.norm() / b.norm();
  EXPECT_NEAR(r.relative_residual, res.norm() / b.norm(), rounding);
  EXPECT_LE(r.relative_residual, 100 * rounding) << "at double precision's rounding level";

  // When the cap ends the single-precision iterations the solve stops there, unconverged.
  s.relative_tolerance = 1e-6;
  s.max_iterations = 1;
  PcgWorkspace ws_capped;
  VecX x_capped = p.guess;
  const PcgResult capped = solve_pcg(A, p.rhs, fixed, s, x_capped, ws_capped);
  EXPECT_FALSE(capped.converged);
  EXPECT_EQ(capped.iterations, 1);
  EXPECT_EQ(ws_capped.ssor_single_fallbacks, 0);
}

TEST(Ssor, StopsOnTheTrueResidualWhateverRatioThePreviousSolveLeft) {
  // The solve predicts when to check the true residual from the ratio |r| / |r^| the
  // previous solve left in the workspace. A ratio far too small (checks every iteration) or
  // far too large (checks late) changes the work, not the answer; and the solve leaves the
  // ratio it measured, not the one it was given.
  test::ClothStepProblem p;
  test::make_cloth_step_problem(33, 0.02, p);
  const BlockMatrix& A = p.matrix();
  const std::vector<char>& fixed = p.pinned();
  PcgSettings s;
  s.relative_tolerance = 1e-7;
  s.preconditioner = Preconditioner::kSsor;
  PcgWorkspace fresh;
  VecX x_fresh = p.guess;
  ASSERT_TRUE(solve_pcg(A, p.rhs, fixed, s, x_fresh, fresh).converged);
  const double measured = fresh.ssor_residual_ratio;
  ASSERT_GT(measured, 0.0);
  VecX b = p.rhs;
  zero_fixed(fixed, b);
  for (double given : {1e-6, 1e6}) {
    PcgWorkspace ws;
    ws.ssor_residual_ratio = given;
    VecX x = p.guess;
    const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
    ASSERT_TRUE(r.converged) << "given ratio " << given;
    VecX res;
    A.multiply(x, res);
    res -= b;
    zero_fixed(fixed, res);
    EXPECT_LE(res.norm(), 1e-7 * b.norm()) << "given ratio " << given;
    EXPECT_LE((x - x_fresh).norm(), 1e-4 * x_fresh.norm()) << "given ratio " << given;
    EXPECT_GT(ws.ssor_residual_ratio, 1e-3 * measured) << "given ratio " << given;
    EXPECT_LT(ws.ssor_residual_ratio, 1e3 * measured) << "given ratio " << given;
  }
}

TEST(Ssor, SinglePrecisionSolvesLeaveTheRatioOfTheirTrueResidual) {
  // The next solve predicts when its run reaches the target from the ratio |r| / |r^| this
  // one leaves (r^ = (B + L)^-1 r). In single precision a run's recursion |r^| keeps shrinking
  // once the true residual has stopped at the copy's rounding, so a ratio taken from the
  // recursion is too large, and a solve started with one aims deeper and leaves a larger one
  // (in a simulation this fed on itself from step to step until a solve never checked and
  // diverged). The ratio left must be the true residual's, here measured again in double
  // precision, whatever ratio the solve was given; and solves repeated with the workspace
  // carried over must not grow their work.
  test::ClothStepProblem p;
  Scene scene = test::cloth_step_scene(33);
  scene.cloth.material.weft = scene.cloth.material.warp = StressCurve::linear(1e5);  // stiff
  scene.cloth.material.shear = StressCurve::linear(1e4);
  test::make_cloth_step_problem(scene, 0.02, p);
  const BlockMatrix& A = p.matrix();
  const std::vector<char>& fixed = p.pinned();
  PcgSettings s;
  s.relative_tolerance = 1e-6;
  s.preconditioner = Preconditioner::kSsor;
  s.ssor_single_precision = true;
  int free_nodes = 0;
  for (char f : fixed) free_nodes += !f;
  SsorOperator S;
  S.assign(A, fixed, ssor_relaxation_for(free_nodes));
  VecX b = p.rhs;
  zero_fixed(fixed, b);
  const auto true_ratio = [&](const VecX& x) {
    VecX r;
    A.multiply(x, r);
    r = b - r;
    zero_fixed(fixed, r);
    SsorOperator::Vector rp, rh;
    S.pad(r, rp);
    rh.resize(rp.size());
    S.solve_lower(rp.data(), rh.data());
    return r.norm() / rh.norm();
  };
  PcgWorkspace fresh;
  VecX x_fresh = p.guess;
  const PcgResult first = solve_pcg(A, p.rhs, fixed, s, x_fresh, fresh);
  ASSERT_TRUE(first.converged);
  EXPECT_NEAR(fresh.ssor_residual_ratio / true_ratio(x_fresh), 1.0, 0.01);
  for (double given : {1e-4, 1e4}) {
    PcgWorkspace ws;
    ws.ssor_residual_ratio = given * fresh.ssor_residual_ratio;
    for (int k = 0; k < 10; ++k) {
      VecX x = p.guess;
      const PcgResult r = solve_pcg(A, p.rhs, fixed, s, x, ws);
      ASSERT_TRUE(r.converged) << "given " << given << ", solve " << k;
      EXPECT_NEAR(ws.ssor_residual_ratio / true_ratio(x), 1.0, 0.01) << "given " << given << ", solve " << k;
      if (k > 0) EXPECT_LE(r.iterations, first.iterations + first.iterations / 4) << "given " << given << ", solve " << k;
    }
  }
}

// Outside 0 < omega < 2 the SSOR operator is not positive definite; the solver refuses
// (0 asks for the automatic choice, which must lie inside and grow with the mesh).
TEST(Ssor, RejectsRelaxationOutsideTheOpenInterval) {
  test::ClothStepProblem p;
  test::make_cloth_step_problem(5, 0.0, p);
  PcgSettings s;
  s.preconditioner = Preconditioner::kSsor;
  PcgWorkspace ws;
  for (double omega : {2.0, -1.0, 2.5}) {
    s.ssor_omega = omega;
    VecX x = p.guess;
    try {
      solve_pcg(p.matrix(), p.rhs, p.pinned(), s, x, ws);
      ADD_FAILURE() << "omega " << omega << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(
          std::string(e.what()),
          "SSOR relaxation must be in (0, 2) (or 0 for automatic), got " + std::to_string(omega));
    }
  }
  double previous = 0.0;
  for (int n : {1, 100, 1089, 16641, 1000000}) {
    const double w = ssor_relaxation_for(n);
    EXPECT_GT(w, previous) << n;
    EXPECT_LT(w, 2.0) << n;
    previous = w;
  }
  s.ssor_omega = 0.0;
  VecX x = p.guess;
  EXPECT_TRUE(solve_pcg(p.matrix(), p.rhs, p.pinned(), s, x, ws).converged);
}

}  // namespace
}  // namespace weft
