#!/usr/bin/env python3
"""Mutation check: does the test suite catch deliberate faults?

Each mutation below is a one-line change to the sources (a file, an exact fragment of its
text that must occur exactly once, and what replaces it). For each one the tool applies it
to a scratch copy of the tree, rebuilds weft and weft_tests there (one build folder for all,
so each mutation is an incremental rebuild), runs the tests, restores the file and records
whether a test failed. The suite should catch every mutation. ctest runs `--list` (test
`tools_mutate_list`), so a fragment that no longer applies fails the suite.

Tests run in two rounds: first the tests named by the mutation's `hint` (a gtest filter:
where the fault should show, so most verdicts come quickly), then, if they all passed, the
whole suite through ctest. A suite that runs past its time limit counts as caught (a fault
that makes a run hang is noticed), and is reported as such. A mutation whose build fails
counts as an error, not as caught: the list must hold faults that compile.

Usage:
  tools/mutate.py                 run every mutation, print a markdown table
  tools/mutate.py --list          list the mutations (checks that each still applies)
  tools/mutate.py --only NAME     run the named mutation(s) (repeatable)
  tools/mutate.py --jobs 2        build and test parallelism
  tools/mutate.py --scratch DIR   where the copy and its build folder live
  tools/mutate.py --prepare       copy the tree and build it, nothing else
  tools/mutate.py --in-place      mutate the working tree and its build/ (no copy; files restored)
Exit status: 0 when every mutation run was caught, 1 when some were missed or failed to
build, 2 for a mutation that no longer applies (its fragment is missing or not unique), 3
when the unmutated tree does not configure, build or pass its tests.
"""
import argparse
import datetime
import os
import re
import shutil
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Mutation:
    def __init__(self, name, area, path, original, replacement, description, hint=""):
        self.name, self.area, self.path = name, area, path
        self.original, self.replacement = original, replacement
        self.description, self.hint = description, hint


M = Mutation
MUTATIONS = [
    # Elements
    M("hinge-weight", "elements", "src/elements/bending.cpp",
      "s.weights = VecX::Constant(1, g.stiffness);", "s.weights = VecX::Constant(1, 0.5 * g.stiffness);",
      "hinge stencil built with half the element's stiffness", "HingePath.*:BendingElement.*"),
    M("hinge-constant", "elements", "src/elements/bending.cpp",
      "g.stiffness = 2.0 * (ha + hb)", "g.stiffness = 3.0 * (ha + hb)",
      "hinge stiffness constant 3 instead of 2", "HingePath.*:BendingElement.*"),
    M("bending-energy-half", "elements", "src/system/cloth.cpp",
      "energy += 0.5 * node(x, i).dot(qx);", "energy += 0.25 * node(x, i).dot(qx);",
      "bending energy of the simulator's path halved", "HingePath.*"),
    M("bending-damping-force", "elements", "src/system/cloth.cpp",
      "node(force, i) -= qx + qv;", "node(force, i) -= qx;",
      "bending damping force dropped from the evaluation", "HingePath.*:EnergyAccount.*"),
    M("bending-jacobian-half", "elements", "src/system/cloth.cpp",
      "stiffness->block[s].diagonal().array() -= q[s];", "stiffness->block[s].diagonal().array() -= 0.5 * q[s];",
      "bending Jacobian halved in the evaluation", "HingePath.*"),
    M("spring-lateral", "elements", "src/elements/spring.cpp",
      "double lateral = 1.0 - rest_length / len;", "double lateral = 1.0;",
      "spring's lateral stiffness ignores the rest length", "SpringElement.*"),
    M("membrane-green-strain", "elements", "src/elements/membrane_kernel.hpp",
      "return {0.5 * (dot3(U, U) - 1.0),", "return {0.5 * (dot3(U, U) - 1.01),",
      "weft strain offset by half a percent", "MembraneElement.*"),
    M("membrane-shear-rate", "elements", "src/elements/membrane_kernel.hpp",
      "return {dot3(U, Ud), dot3(V, Vd), dot3(U, Vd) + dot3(V, Ud)};", "return {dot3(U, Ud), dot3(V, Vd), dot3(U, Vd)};",
      "shear strain rate misses half its terms", "MembraneElement.*:EnergyAccount.*"),
    M("membrane-kw-stress-matrix", "elements", "src/elements/membrane_kernel.hpp",
      "const T kw_u = area * (du * U[c] + ds * V[c] + k.s00 * dU[c] + k.s01 * dV[c]);",
      "const T kw_u = area * (du * U[c] + ds * V[c] + k.s00 * dU[c]);",
      "K w misses a stress-matrix term", "MembraneElement.*:ClothAssembly.*"),
    # Integrators
    M("guard-last-resort-newton", "integrators", "src/integrate/energy_guard.cpp",
      "if (c_.settings.guard_last_resort_newton && newton_limit() < kGuardLastResortNewton &&",
      "if (false && newton_limit() < kGuardLastResortNewton &&",
      "the guarded midpoint keeps its linearised last resort", "ContactResponse.*"),
    M("guard-depth-after-contacts", "integrators", "src/integrate/energy_guard.cpp",
      "if (contacts_acted && !(halves_gain <= kGuardFutileShare * gain) && d_.guard_depth == splits + 1)",
      "if (false && contacts_acted && !(halves_gain <= kGuardFutileShare * gain) && d_.guard_depth == splits + 1)",
      "the guard carries a halving whose halves showed no turning elements into the next steps",
      "GuardedMidpoint.*"),
    M("viscous-work-half", "integrators", "src/integrate/integrator.cpp",
      "s.viscous_dissipated -= dt * system_.step_viscous_power(s.x, d_.mean_velocity, d_.step);",
      "s.viscous_dissipated -= 0.5 * dt * system_.step_viscous_power(s.x, d_.mean_velocity, d_.step);",
      "semi-implicit step accounts half the viscous dissipation", "EnergyAccount.*"),
    M("rk45-error-weight", "integrators", "src/integrate/explicit_steps.cpp",
      "b4[7] = {5179.0 / 57600,", "b4[7] = {5178.0 / 57600,",
      "one weight of RK45's embedded error estimator changed", "Rk45ErrorEstimate.*"),
    M("rk45-dissipation-weights", "integrators", "src/integrate/explicit_steps.cpp",
      "dissipated -= h * b5[st] * power[st];", "dissipated -= h * b4[st] * power[st];",
      "RK45 accounts viscous work with the embedded weights", "EnergyAccount.*"),
    M("rk4-dissipation", "integrators", "src/integrate/explicit_steps.cpp",
      "s.viscous_dissipated -= dt / 6 * (p1 + 2 * p2 + 2 * p3 + p4);",
      "s.viscous_dissipated -= dt / 6 * (p1 + 2 * p2 + 2 * p3 + 2 * p4);",
      "RK4 viscous work with a wrong stage weight", "EnergyAccount.*"),
    M("bdf2-step", "integrators", "src/integrate/integrator.cpp",
      "(2 * alpha - 1) / (2 * alpha + 1), 2 * dt / (2 * alpha + 1), stats);",
      "(2 * alpha - 1) / (2 * alpha + 1), 2 * dt / (2 * alpha + 1.5), stats);",
      "progressive BDF-2's step coefficient wrong", "ConvergenceOrder.*:OneSpring.*"),
    M("alpha-rhs", "integrators", "src/integrate/integrator.cpp",
      "if (alpha > 0.0) d_.rhs += alpha * dt_b * d_.step.stiffness_times_w;",
      "if (alpha > 0.0) d_.rhs += dt_b * d_.step.stiffness_times_w;",
      "right-hand side's K w term without alpha", "ConvergenceOrder.*:OneSpring.*"),
    M("forward-euler-dissipation", "integrators", "src/integrate/integrator.cpp",
      "s.viscous_dissipated -= dt * d_.step.viscous_power;", "s.viscous_dissipated -= 0.5 * dt * d_.step.viscous_power;",
      "forward Euler accounts half the viscous work", "EnergyAccount.*"),
    M("bdf2-guard-off", "integrators", "src/integrate/integrator.cpp",
      "guarded_bdf2_step(s, dt, stats);", "bdf2_step(s, dt, alpha, stats);",
      "bdf2-alpha-guarded steps without its guard", "GuardedBdf2.*"),
    M("guard-energy-cache-stale", "integrators", "src/integrate/integrator.cpp",
      "if (!(d_.energy_x.size() == x.size() && d_.energy_x == x)) {", "if (d_.energy_x.size() != x.size()) {",
      "the guard's end-of-step energy kept whatever the positions", "GuardedMidpoint.*:GuardedBdf2.*"),
    M("potential-energy-bending", "integrators", "src/system/cloth.cpp",
      "elastic += 0.5 * node(x, i).dot(qx);", "elastic += 0.0 * node(x, i).dot(qx);",
      "the guard's energy without bending", "ClothMaterials.*"),
    # Damping
    M("membrane-required-viscosity", "damping", "src/damping/adaptive.cpp",
      "? 2.0 * damping_ratio * std::sqrt(tangent_moduli[k] / as)", "? 1.0 * damping_ratio * std::sqrt(tangent_moduli[k] / as)",
      "adaptive damping reaches half the target ratio on triangles", "AdaptiveDamping.*"),
    M("bending-gamma", "damping", "src/system/cloth.cpp",
      "? 2.0 * zeta / std::sqrt(S) : 0.0;", "? 1.0 * zeta / std::sqrt(S) : 0.0;",
      "adaptive damping reaches half the target ratio on bending stencils", "AdaptiveDamping.*"),
    M("bending-viscous-power-step", "damping", "src/system/cloth.cpp",
      "power -= 2 * (vi[0] * qv[0] + vi[1] * qv[1] + vi[2] * qv[2]) + qd[d]",
      "power -= (vi[0] * qv[0] + vi[1] * qv[1] + vi[2] * qv[2]) + qd[d]",
      "step's bending viscous power misses the off-diagonal half", "EnergyAccount.*"),
    M("damping-ratio-range", "damping", "src/io/scene.cpp",
      "!(*s.damping_ratio >= 0 && *s.damping_ratio <= 10))", "!(*s.damping_ratio >= 0 && *s.damping_ratio <= 100))",
      "damping ratio range widened to [0, 100] in scene validation", "SceneKeys.*"),
    M("damping-ratio-key-range", "damping", "src/io/scene.cpp",
      's.damping_ratio = d.number_in("ratio", 0, 10, false);', 's.damping_ratio = d.number_in("ratio", 0, 100, false);',
      "damping.ratio key accepts up to 100", "SceneKeys.*"),
    # Materials
    M("spline-end-limiter", "materials", "src/material/stress_curve.cpp",
      "if (d0 * d1 < 0.0 && std::abs(m) > std::abs(3.0 * d0)) return 3.0 * d0;",
      "if (false) return 3.0 * d0;",
      "end slope of the stress-strain spline no longer limited", "SplineCurve.*:SplineLimiters.*"),
    M("spline-interior-limiter", "materials", "src/material/stress_curve.cpp",
      "c.slope_[k] = (w1 + w2) / (w1 / d[k - 1] + w2 / d[k]);", "c.slope_[k] = 0.5 * (d[k - 1] + d[k]);",
      "interior slopes of the spline are plain means (no monotone limiter)", "SplineCurve.*:SplineLimiters.*"),
    M("areal-density-unit", "materials", "src/io/material_file.cpp",
      '{"g/m2", 1e-3},', '{"g/m2", 1e-2},',
      "g/m2 converted with a wrong factor", "Material*"),
    # Solvers
    M("single-precision-restart", "solvers", "src/linalg/pcg.cpp",
      "if (run.breakdown || !(rnorm < 0.5 * run_start)) {", "if (run.breakdown) {",
      "single-precision SSOR never falls back to double when a restart stalls", "Ssor*"),
    M("single-precision-run-target", "solvers", "src/linalg/pcg.cpp",
      "const double run_target = std::max(target, kRunReduction * run_start);", "const double run_target = target;",
      "single-precision runs aim straight for the target (no restart from the true residual)",
      "Ssor*:RunCommand.Preconditioner*"),
    M("single-precision-ratio", "solvers", "src/linalg/pcg.cpp",
      "if (it > 0 && rnorm > 0) {", "if (false && it > 0 && rnorm > 0) {",
      "single-precision solves leave the ratio they were given, not their true residual's", "Ssor*"),
    M("runaway-stop", "integrators", "src/sim/model_data.cpp",
      "if (!stop_on_runaway || M.scene.integrator.method == Method::kRk45) {", "if (true) {",
      "a run steps a blowing-up cloth on to the frame's end", "InstabilityRule.*"),
    M("backward-euler-newton", "integrators", "src/integrate/integrator.cpp",
      "const bool gained = !(d_.guard_gain <= kBackwardEulerNewtonShare * d_.guard_scale);",
      "const bool gained = false;",
      "a backward Euler step that puts energy in is kept linearised", "BackwardEulerNewton.*"),
    M("warm-start-off", "solvers", "src/integrate/integrator.cpp",
      "if (!d_.history.guess(d_.rhs, d_.dv)) {", "if (true) {",
      "warm start from the solution history switched off", "WarmStart.*"),
    M("warm-start-record", "solvers", "src/integrate/integrator.cpp",
      "if (d_.contacts.empty() && pass == 0) {", "if (false) {",
      "solutions never recorded for the warm start", "WarmStart.*"),
    M("pcg-step", "solvers", "src/linalg/pcg.cpp",
      "xp[k] += a * pp[k];", "xp[k] += 0.99 * a * pp[k];",
      "block-Jacobi and multigrid CG move x 1% short of the residual's step", "Pcg*:Multigrid*:BlockJacobi*"),
    # Scene validation and scene keys
    M("grid-pin-range", "scene", "src/io/scene.cpp",
      "if (i >= c.grid->vertices_u || i < -c.grid->vertices_u", "if (i > c.grid->vertices_u || i < -c.grid->vertices_u",
      "grid pin one past the last column accepted", "SceneKeys.*"),
    M("vertex-pin-range", "scene", "src/io/scene.cpp",
      "if (p >= mesh.num_vertices())", "if (p > mesh.num_vertices())",
      "vertex pin equal to the vertex count accepted", "SceneKeys.*"),
    M("placement-translation", "scene", "src/io/scene.cpp",
      "(R * m.positions.row(i).transpose() + spec.translation)", "(R * m.positions.row(i).transpose() + 0.5 * spec.translation)",
      "placement.translation applied at half length", "SceneKeys.*"),
    M("placement-rotation", "scene", "src/io/scene.cpp",
      "const Vec3 r = spec.rotation_deg * (M_PI / 180.0);", "const Vec3 r = spec.rotation_deg * (M_PI / 360.0);",
      "placement.rotation_deg read as half angles", "SceneKeys.*"),
    M("initial-velocity", "scene", "src/sim/model_data.cpp",
      "if (!cloth.pinned[i]) node(s.v, i) = scene.cloth.initial_velocity;",
      "if (!cloth.pinned[i]) node(s.v, i) = 0.5 * scene.cloth.initial_velocity;",
      "initial_velocity given at half speed", "SceneKeys.*"),
    M("uv-scale", "scene", "src/io/obj_file.cpp",
      "m.pattern[i] = uv_scale * Vec2(", "m.pattern[i] = Vec2(",
      "OBJ uv_scale ignored", "SceneKeys.*"),
    M("best-fit-plane", "scene", "src/io/obj_file.cpp",
      "const Vec3 e1 = svd.matrixV().col(0), e2 = svd.matrixV().col(1);",
      "const Vec3 e1 = svd.matrixV().col(0), e2 = svd.matrixV().col(2);",
      "pattern of an OBJ without texture coordinates projected on the wrong plane", "SceneKeys.*"),
    M("rk45-tolerance-key", "scene", "src/io/scene.cpp",
      "(s.integrator.method == Method::kRk45 ? s.integrator.error_tolerance : s.integrator.cg_tolerance) = tol;",
      "(s.integrator.method != Method::kRk45 ? s.integrator.error_tolerance : s.integrator.cg_tolerance) = tol;",
      "integrator.tolerance given to the wrong solver", "SceneKeys.*"),
    M("gravity-key", "scene", "src/io/scene.cpp",
      's.gravity = r.vec3_within("gravity", kMaxGravity_m_s2, "m/s^2");',
      's.gravity = -r.vec3_within("gravity", kMaxGravity_m_s2, "m/s^2");',
      "gravity key read with the wrong sign", "SceneKeys.*"),
    M("bending-model-key", "scene", "src/system/cloth_model.cpp",
      'if (name == "plate") return BendingModel::kPlate;', 'if (name == "plate") return BendingModel::kHinge;',
      "bending_model plate builds hinges", "SceneKeys.*:PlateBending.*"),
    M("shifted-rows", "scene", "src/mesh/mesh.cpp",
      "(shifted && j % 2 ? 0.5 : 0.0)", "(shifted && j % 2 ? 0.25 : 0.0)",
      "shifted-rows grid pattern shifts odd rows by a quarter cell", "SceneKeys.*"),
    M("proximity-reuse-normals", "contacts", "src/collision/self_contact.cpp",
      "      if (!s.touching) continue;", "      if (true) continue;",
      "a reused proximity keeps the first search's touching normals", "SelfContact.*"),
    M("still-layer-holds", "contacts", "src/collision/self_contact.cpp",
      "if (c.still_surface && !c.kinematic && node(v, i).norm() <= tunables_.held_rest_speed) ++resting[side];",
      "if (false) ++resting[side];",
      "no holds against a layer a still collider holds at rest", "SelfContact.*"),
    M("self-culling-contour", "contacts", "src/collision/self_culling.cpp",
      "        pass = clearance >= kSafety * r;",
      "        pass = true;",
      "self-collision culling passes over regions whatever their contours", "SelfCulling.*"),
    M("self-culling-contour-motion", "contacts", "src/collision/self_culling.cpp",
      "      const auto qa = project(xb, s.a), qb = project(xb, s.b);",
      "      const auto qa = project(xa, s.a), qb = project(xa, s.b);",
      "self-collision culling measures a moving cloth's contour at the step's start only", "SelfCulling.*"),
    M("self-culling-altitude", "contacts", "src/collision/self_culling.cpp",
      "      if (bound >= kSafety * r) {", "      if (bound >= 0) {",
      "self-collision culling ignores its triangles' altitudes", "SelfCulling.*"),
    M("contact-prediction-reach", "contacts", "src/collision/collider_contacts.cpp",
      "const double reach = 2 * thickness + dt * node(v, i).norm() + c->step_motion();",
      "const double reach = 2 * thickness;",
      "the solve's collider contacts no longer reach as far as the node's motion in the step",
      "MeshCollider.*:ContactResponse.*"),
    M("self-friction-coefficient", "contacts", "src/collision/self_contact.cpp",
      "change -= std::min(friction_ * normal_change, slide) / slide * tangential;",
      "change -= std::min(1.0 * normal_change, slide) / slide * tangential;",
      "the cloth's repulsions take friction 1 instead of the cloth's coefficient", "SelfContactFriction.*"),
    M("collider-end-half-thickness", "contacts", "src/collision/collider_contacts.cpp",
      "if (s.distance >= thickness) continue;", "if (s.distance >= 0.5 * thickness) continue;",
      "collider contacts at the step's end held only within half the thickness", "ColliderContactsAtTheEnd.*"),
    M("moved-mesh-collider-shared-motion", "contacts", "src/sim/model_data.cpp",
      "const RigidMotion* motion = &D.collider_motions[k];", "const RigidMotion* motion = &M.scene.colliders[k].motion;",
      "a mesh collider reads the model's motion, so move_collider does not move its surface", "MovedMeshCollider.*"),
    # Garments
    M("weld-one-side", "garment", "src/garment/sewing.cpp",
      "m.positions.row(w) += positions.row(i);", "m.positions.row(w) = (members[w] + 1) * positions.row(i);",
      "a welded vertex put at one of its vertices instead of their mean", "Weld.*:SewingStage.*"),
    M("step-motion-end-velocity", "garment", "src/integrate/integrator.cpp",
      "  d_.dv = f * d_.dv - ((1 - f) / alpha) * s.v;", "  d_.dv = f * d_.dv;",
      "a step held to the motion limit keeps an end velocity that does not match its displacement",
      "StepMotionLimit.*"),
    # Checkpoints
    M("fingerprint-cloth-friction", "checkpoint", "src/sim/model_data.cpp",
      "for (double d : {M.scene.cloth.thickness, M.scene.cloth.friction}) w.f64(d);",
      "for (double d : {M.scene.cloth.thickness}) w.f64(d);",
      "the model's fingerprint leaves out the cloth's friction", "CheckpointFingerprint.*"),
    M("fingerprint-curves", "checkpoint", "src/sim/model_data.cpp",
      "for (const StressCurve* c : {&m.weft, &m.warp, &m.shear}) put(w, *c);",
      "for (const StressCurve* c : {&m.weft, &m.warp}) put(w, *c);",
      "the model's fingerprint leaves out the shear curve", "CheckpointFingerprint.*"),
    M("fingerprint-collider-friction", "checkpoint", "src/sim/model_data.cpp",
      "for (double d : {c.thickness, c.friction, c.radius, c.edge_radius, c.scale}) w.f64(d);",
      "for (double d : {c.thickness, c.radius, c.edge_radius, c.scale}) w.f64(d);",
      "the model's fingerprint leaves out the colliders' friction", "CheckpointFingerprint.*"),
    # Input checks at their edges
    M("obj-texcoord-range", "input", "src/io/obj_file.cpp",
      "if (corner.texcoord >= texcoords)", "if (corner.texcoord > texcoords)",
      "OBJ texture coordinate one past the last accepted", "ObjReader*"),
    M("obj-vertex-range", "input", "src/io/obj_file.cpp",
      "if (corner.vertex >= out_.vertex_count())", "if (corner.vertex > out_.vertex_count())",
      "OBJ vertex one past the last accepted", "ObjReader*"),
    M("cloth-friction-range", "input", "src/io/scene.cpp",
      'if (r.has("friction")) c.friction = r.number_in("friction", 0, kMaxFriction, false);\n  if (r.has("self_collision"))',
      'if (r.has("friction")) c.friction = r.number("friction");\n  if (r.has("self_collision"))',
      "the cloth's friction taken without its range check", "SceneRanges.*"),
    # Damping of a cloth of several materials
    M("damping-first-material", "damping", "src/system/cloth_damping.cpp",
      "const Material& material = model_.material_of(t);", "const Material& material = model_.materials.front();",
      "adaptive damping reads the first material for every triangle (tabulated curves)", "AdaptiveDamping*"),
    M("damping-first-material-linear", "damping", "src/system/cloth_damping.cpp",
      "const Vec3& E = moduli[model_.material_index(t)];", "const Vec3& E = moduli[0];",
      "adaptive damping reads the first material's moduli for every triangle (linear curves)", "AdaptiveDamping*"),
    # Newton
    M("newton-no-halving", "integrators", "src/integrate/newton.cpp",
      "for (int halving = 0; halving <= kNewtonMaxHalvings; ++halving) {", "for (int halving = 0; halving <= 0; ++halving) {",
      "Newton's line search allowed no halvings", "NewtonStep.*"),
    # Outputs and run checks
    M("instability-threshold", "outputs", "src/sim/model_data.cpp",
      "+ cloth.mass.sum() * M.scene.gravity.norm() * (hi - lo).norm();",
      "+ 100 * cloth.mass.sum() * M.scene.gravity.norm() * (hi - lo).norm();",
      "energy-rise instability threshold's gravity term times 100", "InstabilityRule.*"),
    M("kinetic-energy", "outputs", "src/sim/model_data.cpp",
      "kinetic += 0.5 * m[i] * node(s.v, i).squaredNorm();", "kinetic += 0.49 * m[i] * node(s.v, i).squaredNorm();",
      "kinetic energy reported 2% low", "EnergyAccount.*:EnergyBalance.*"),
    M("energy-csv-column", "outputs", "src/sim/simulation.cpp",
      "e.gravity, e.viscous_dissipated, e.numerical_dissipated, e.contact_work, e.total());",
      "e.gravity, e.numerical_dissipated, e.viscous_dissipated, e.contact_work, e.total());",
      "energy.csv's dissipation columns swapped", "EnergyCsv.*:RunCommand.*"),
    M("added-viscosity-output", "outputs", "src/system/cloth_damping.cpp",
      "sum[k] += model_.membranes[t].area * added;", "sum[k] += added;",
      "per-vertex added viscosity not area-weighted", "DampingOutput.*"),
]


def sh(cmd, cwd, timeout=None, env=None):
    """Runs cmd; returns (exit status or 'timeout', output)."""
    try:
        p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=timeout, env=env)
        return p.returncode, p.stdout
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        return "timeout", out


def fail(status, message):
    print(message, file=sys.stderr)
    sys.exit(status)


def check_applies(m, root):
    with open(os.path.join(root, m.path), encoding="utf-8") as f:
        text = f.read()
    n = text.count(m.original)
    if n != 1:
        fail(2, f"mutation {m.name}: {m.path} holds its fragment {n} times (expected once): {m.original!r}")
    return text


def tracked_files(root):
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=root, stdout=subprocess.PIPE,
                         text=True, check=True).stdout
    return [p for p in out.splitlines() if os.path.isfile(os.path.join(root, p))]


def sync_tree(root, tree):
    """Makes `tree` a copy of the working tree's files (tracked and untracked, not ignored),
    rewriting only files that differ so that the build there stays incremental."""
    files = set(tracked_files(root))
    for rel in files:
        src, dst = os.path.join(root, rel), os.path.join(tree, rel)
        with open(src, "rb") as f:
            data = f.read()
        if os.path.exists(dst):
            with open(dst, "rb") as f:
                if f.read() == data:
                    continue
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        # A fresh modification time (not the source's, which may be older than the objects
        # built from the previous copy): the build then sees the change.
        shutil.copy(src, dst)
    for top in ("src", "app", "include", "tests", "scenes", "data"):
        for dirpath, _, names in os.walk(os.path.join(tree, top)):
            for name in names:
                rel = os.path.relpath(os.path.join(dirpath, name), tree)
                if rel not in files:
                    os.remove(os.path.join(dirpath, name))


def configure(tree, build):
    if os.path.exists(os.path.join(build, "build.ninja")):
        return
    cmd = ["cmake", "-S", tree, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release", "-DWEFT_NATIVE=OFF",
           "-DWEFT_BUILD_BENCH=OFF"]
    if shutil.which("ccache"):
        cmd.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
    rc, out = sh(cmd, tree)
    if rc != 0:
        fail(3, "configuring the build failed:\n" + out)


def build(build_dir, jobs):
    return sh(["cmake", "--build", build_dir, "-j", str(jobs), "--target", "weft", "weft_tests"], build_dir)


FAILED_GTEST = re.compile(r"^\[  FAILED  \] ([\w/.]+)", re.M)
FAILED_CTEST = re.compile(r"Test\s+#\d+: (\S+) \.*\**\s*(Failed|Timeout|Exception|Subprocess aborted|Not Run)", re.M)


def run_tests(build_dir, hint, jobs, suite_timeout, test_timeout):
    """Returns (verdict, detail): caught / caught-by-timeout / missed."""
    if hint:
        rc, out = sh([os.path.join(build_dir, "weft_tests"), "--gtest_filter=" + hint], build_dir,
                     timeout=suite_timeout)
        if rc == "timeout":
            return "caught (timeout)", f"{hint} ran past {suite_timeout} s"
        if rc != 0:
            m = FAILED_GTEST.search(out)
            return "caught", m.group(1) if m else f"weft_tests exited {rc}"
    # tools_mutate_list checks that every fragment applies, which a mutated tree always fails: left out.
    rc, out = sh(["ctest", "-j", str(jobs), "--stop-on-failure", "--timeout", str(test_timeout),
                  "-E", "^tools_mutate_list$"], build_dir,
                 timeout=suite_timeout)
    if rc == "timeout":
        return "caught (timeout)", f"suite ran past {suite_timeout} s"
    if rc != 0:
        m = FAILED_CTEST.search(out)
        if m and m.group(2) == "Timeout":
            return "caught (timeout)", m.group(1)
        return "caught", m.group(1) if m else f"ctest exited {rc}"
    return "missed", ""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--list", action="store_true", help="list the mutations and check that each applies")
    ap.add_argument("--only", action="append", default=[], metavar="NAME", help="run only this mutation")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--scratch", default=os.path.join(ROOT, "build-mutate"),
                    help="folder for the tree's copy and its build (default: build-mutate/)")
    ap.add_argument("--suite-timeout", type=int, default=1800, help="seconds a test run may take")
    ap.add_argument("--test-timeout", type=int, default=600, help="seconds one ctest test may take")
    ap.add_argument("--in-place", action="store_true",
                    help="mutate the working tree itself and use its build/ folder (no copy, no second full "
                         "build); refuses files with uncommitted changes, restores each file after its run")
    ap.add_argument("--prepare", action="store_true", help="only copy the tree and build it (ahead of a run)")
    ap.add_argument("--skip-baseline", action="store_true", help="do not check that the unmutated tree passes")
    args = ap.parse_args()

    names = {m.name for m in MUTATIONS}
    if len(names) != len(MUTATIONS):
        fail(2, "two mutations share a name")
    for n in args.only:
        if n not in names:
            fail(2, f"no mutation named {n!r} (see --list)")
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    for m in chosen:
        check_applies(m, ROOT)
    if args.list:
        for m in chosen:
            print(f"{m.name:30} {m.area:12} {m.path:34} {m.description}")
        print(f"{len(chosen)} mutations")
        return 0

    if args.in_place:
        tree, build_dir = ROOT, os.path.join(ROOT, "build")
        dirty = subprocess.run(["git", "status", "--porcelain", "--"] + sorted({m.path for m in chosen}), cwd=ROOT,
                               stdout=subprocess.PIPE, text=True, check=True).stdout
        if dirty:
            fail(2, "--in-place needs the mutated files committed:\n" + dirty)
        # A terminated run still restores the file it mutated (the finally clause below).
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    else:
        tree, build_dir = os.path.join(args.scratch, "tree"), os.path.join(args.scratch, "build")
        os.makedirs(tree, exist_ok=True)
        sync_tree(ROOT, tree)
    configure(tree, build_dir)
    rc, out = build(build_dir, args.jobs)
    if rc != 0:
        fail(3, "the unmutated tree does not build:\n" + out[-4000:])
    if args.prepare:
        return 0
    if not args.skip_baseline:
        started = time.time()
        hints = ":".join(sorted({h for m in chosen for h in m.hint.split(":") if h}))
        verdict, detail = run_tests(build_dir, hints, args.jobs, args.suite_timeout, args.test_timeout) \
            if args.only else run_tests(build_dir, "", args.jobs, args.suite_timeout, args.test_timeout)
        if verdict != "missed":
            fail(3, f"the unmutated tree fails its tests ({verdict}: {detail}); fix that first")
        print(f"baseline: the unmutated tree passes ({time.time() - started:.0f} s)", file=sys.stderr, flush=True)

    rows = []
    for k, m in enumerate(chosen, 1):
        path = os.path.join(tree, m.path)
        original = check_applies(m, tree)
        started = time.time()
        try:
            with open(path, "w", encoding="utf-8") as f:
                f.write(original.replace(m.original, m.replacement))
            rc, out = build(build_dir, args.jobs)
            if rc != 0:
                verdict, detail = "BUILD FAILED", out.strip().splitlines()[-1] if out.strip() else ""
            else:
                verdict, detail = run_tests(build_dir, m.hint, args.jobs, args.suite_timeout, args.test_timeout)
        finally:
            with open(path, "w", encoding="utf-8") as f:
                f.write(original)
        rows.append((m, verdict, detail))
        print(f"[{k}/{len(chosen)}] {m.name}: {verdict} {detail} ({time.time() - started:.0f} s)",
              file=sys.stderr, flush=True)
    build(build_dir, args.jobs)  # leave the scratch build matching the tree

    print(f"Mutation check, {datetime.date.today().isoformat()}: {len(rows)} mutations, "
          f"{sum(r[1].startswith('caught') for r in rows)} caught.\n")
    print("| Mutation | Area | File | Fault | Result | First failing test |")
    print("|---|---|---|---|---|---|")
    for m, verdict, detail in rows:
        print(f"| {m.name} | {m.area} | {m.path} | {m.description} | {verdict} | {detail} |")
    return 0 if all(r[1].startswith("caught") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
