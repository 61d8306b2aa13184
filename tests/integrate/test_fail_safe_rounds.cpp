// Several fail-safes in one step (docs/collisions.md, "One fail-safe after the other"): when a
// later handler's correction undoes the first one's, the first looks again at the nodes it
// moved and the others correct after it, for a few rounds; a step still undone in the last
// round is reported invalid and taken again as two halves.
#include <gtest/gtest.h>

#include <vector>

#include "collision/colliders.hpp"
#include "integrate/integrator.hpp"
#include "support/spring_system.hpp"

using namespace weft;
using weft::test::Spring;
using weft::test::SpringSystem;

namespace {

// A floor at y = 0: its fail-safe lifts nodes below it onto it. Round 0 looks at every node;
// a later round only at those whose position changed since its last call (report.left), as
// the colliders' fail-safe does. It records the nodes it looked at in later rounds.
class Floor : public ContactHandler {
 public:
  std::vector<int> looked_at_later;
  int calls = 0;
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>&) override {}
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX& x1, VecX& v1, double, double, ContactReport& report) override {
    ++calls;
    for (int i = 0; i < static_cast<int>(x1.size() / 3); ++i) {
      if (report.round > 0) {
        if (node(x1, i) == node(*report.left, i)) continue;
        looked_at_later.push_back(i);
      }
      if (x1[3 * i + 1] >= 0) continue;
      x1[3 * i + 1] = 0;
      v1[3 * i + 1] = std::max(v1[3 * i + 1], 0.0);
      ++report.fail_safe_moves;
    }
  }
};

// A correction after the floor's that pushes node 0 1 cm into it: in its first call of every
// step only (`every_call` false), or in every call.
class Pusher : public ContactHandler {
 public:
  explicit Pusher(bool every_call) : every_call_(every_call) {}
  int calls = 0;
  void detect(const VecX&, const VecX&, double, double, std::vector<NodeContact>&) override {}
  void detect_end(const VecX&, const VecX&, double, double, const std::vector<char>&, std::vector<NodeContact>&) override {}
  void finish_step(const VecX&, VecX& x1, VecX&, double t, double, ContactReport& report) override {
    ++calls;
    if (!every_call_ && t == last_t_) return;
    last_t_ = t;
    x1[1] = -0.01;
    ++report.fail_safe_moves;
  }

 private:
  bool every_call_;
  double last_t_ = -1;
};

IntegratorSettings backward_euler() {
  IntegratorSettings st;
  st.alpha = 1.0;
  st.dt = 0.01;
  st.cg_tolerance = 1e-12;
  st.backward_euler_newton = false;  // each step taken once: the rounds are counted per step
  return st;
}

// Two free nodes of 1 kg at rest 10 cm above the floor (node 0 at `height0`), joined by a
// spring at its rest length, stepped once by backward Euler with `handlers` in order.
struct TwoNodes {
  SpringSystem sys{VecX::Constant(2, 1.0), {Spring{0, 1, 100.0, 1.0, 0.0}}};
  State s;
  StepStatistics st;
  TwoNodes(std::vector<ContactHandler*> handlers, double height0 = 0.1,
           int max_step_halvings = IntegratorSettings{}.max_step_halvings) {
    s.x = VecX::Zero(6);
    s.x << 0, height0, 0, 1, 0.1, 0;
    s.v = VecX::Zero(6);
    IntegratorSettings settings = backward_euler();
    settings.max_step_halvings = max_step_halvings;
    Integrator in(sys, settings);
    for (ContactHandler* h : handlers) in.add_contact_handler(h);
    in.step(s, 0.01, st);
  }
};

}  // namespace

TEST(FailSafeRounds, TheFirstFailSafePutsBackWhatALaterOneUndid) {
  Floor floor;
  Pusher pusher(false);
  const TwoNodes run({&floor, &pusher});
  const VecX& x = run.s.x;
  const StepStatistics& st = run.st;
  // Without the later round the pusher's 1 cm would stand.
  EXPECT_EQ(x[1], 0.0);
  EXPECT_EQ(x[4], 0.1);
  // Round 0 (both), round 1 (the floor moves node 0, the pusher after it), round 2 not
  // needed: nothing moved since the floor's last call.
  EXPECT_EQ(floor.calls, 2);
  EXPECT_EQ(pusher.calls, 2);
  EXPECT_EQ(floor.looked_at_later, std::vector<int>{0});  // only the node the pusher moved
  EXPECT_EQ(st.halved_steps, 0);
  EXPECT_EQ(st.failed_contact_steps, 0);
}

TEST(FailSafeRounds, AStepAFailSafeKeepsUndoingIsReportedInvalidAndHalved) {
  Floor floor;
  Pusher pusher(true);
  const TwoNodes run({&floor, &pusher});
  const VecX& x = run.s.x;
  const StepStatistics& st = run.st;
  // Every attempt runs both kFailSafeRounds times more, the pusher last (for the cloth's own
  // fail-safe: no crossing of the cloth with itself); the step is halved as often as it may be
  // and the last attempt stands.
  EXPECT_GT(st.failed_contact_steps, 0);
  EXPECT_EQ(st.halved_steps, (1 << IntegratorSettings{}.max_step_halvings) - 1);
  EXPECT_EQ(floor.calls, (kFailSafeRounds + 1) * ((2 << IntegratorSettings{}.max_step_halvings) - 1));
  EXPECT_EQ(pusher.calls, floor.calls);
  EXPECT_EQ(x[1], -0.01);
}

TEST(FailSafeRounds, AnInvalidStepIsHalvedAsOftenAsTheSettingAllows) {
  // integrator.max_step_halvings: each attempt that stays invalid is taken again as two halves
  // down to that depth, so a step always undone takes 2^h - 1 halvings and 2^(h+1) - 1 attempts.
  for (const int h : {0, 1, 5}) {
    SCOPED_TRACE(h);
    Floor floor;
    Pusher pusher(true);
    const TwoNodes run({&floor, &pusher}, 0.1, h);
    EXPECT_EQ(run.st.halved_steps, (1 << h) - 1);
    EXPECT_EQ(floor.calls, (kFailSafeRounds + 1) * ((2 << h) - 1));
  }
}

TEST(FailSafeRounds, OneFailSafeAloneRunsOnce) {
  Floor floor;
  const TwoNodes run({&floor}, -0.05);
  const VecX& x = run.s.x;
  EXPECT_EQ(floor.calls, 1);
  EXPECT_EQ(x[1], 0.0);
}

// The colliders' fail-safe in a later round: of the nodes within a quarter of the thickness of a
// plane, only those the other handlers moved since its last call by at least the difference to
// half the thickness (which the first round leaves every node at or above) are put back, at
// half the thickness; a node moved that ends above the quarter stays where it is.
TEST(FailSafeRounds, TheCollidersLaterRoundPutsBackOnlyMovedNodesWithinAQuarterAtHalfTheThickness) {
  ColliderSpec spec;
  spec.shape = ColliderShape::kPlane;
  spec.thickness = 0.004;
  const auto plane = make_analytic_collider(spec);
  const int n = 4;
  const VecX mass = VecX::Constant(n, 1e-3);
  const std::vector<char> fixed(n, 0);
  ColliderContacts contacts({plane.get()}, mass, fixed, {});
  // Heights at the end of the step, in thicknesses: node 0 moved there from 0.6 (by 0.45, put
  // back), node 1 from 0.16 (by 0.01: not moved by the others, left alone), node 2 from 0.6 to
  // 0.3 (above the quarter), node 3 from 0.5 into the plane (-0.1, put back).
  const double from[n] = {0.6, 0.16, 0.6, 0.5}, to[n] = {0.15, 0.15, 0.3, -0.1};
  VecX x0 = VecX::Zero(3 * n), left = x0, x1 = x0, v1 = VecX::Zero(3 * n);
  for (int i = 0; i < n; ++i) {
    x0[3 * i] = left[3 * i] = x1[3 * i] = 0.1 * i;
    left[3 * i + 1] = x0[3 * i + 1] = from[i] * spec.thickness;
    x1[3 * i + 1] = to[i] * spec.thickness;
  }
  ContactReport report;
  report.round = 1;
  report.left = &left;
  contacts.finish_step(x0, x1, v1, 0.0, 0.005, report);
  EXPECT_EQ(report.fail_safe_moves, 2);
  EXPECT_NEAR(x1[1], 0.5 * spec.thickness, 1e-12);
  EXPECT_EQ(x1[4], 0.15 * spec.thickness);
  EXPECT_EQ(x1[7], 0.3 * spec.thickness);
  EXPECT_NEAR(x1[10], 0.5 * spec.thickness, 1e-12);
  // The first round, from the same end: every node within half the thickness, at the thickness.
  for (int i = 0; i < n; ++i) x1[3 * i + 1] = to[i] * spec.thickness;
  ContactReport first;
  contacts.finish_step(x0, x1, v1, 0.0, 0.005, first);
  EXPECT_EQ(first.fail_safe_moves, 4);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(x1[3 * i + 1], spec.thickness, 1e-12) << i;
}
