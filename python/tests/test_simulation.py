# The Python module against the command: the same scene stepped from Python gives `weft run`'s
# frames and energies, the numpy arrays are the simulation's own, and bad input raises the
# command's message.
import gc
import json

import numpy as np
import pytest

import weft
from conftest import run_weft


def write_scene(path, scene):
    path.write_text(json.dumps(scene))
    return path


def step_like_weft_run(sim, out):
    """What run_simulation does: the frames at 0 and every frame interval, each recorded and
    written as an OBJ frame."""
    out.mkdir()
    for f, t in enumerate(sim.frame_times):
        if f > 0:
            sim.advance(t)
        sim.record_frame()
        sim.write_obj(out / f"frame_{f:05d}.obj")


# Python calls the library's Simulation::advance_to at the frame times and the same writers as
# `weft run`, so the files are the same bytes, not merely close.
@pytest.mark.parametrize("scene_name", ["sheet", "sphere"])
def test_stepping_gives_the_frames_and_energies_of_weft_run(tmp_path, scene_name, request):
    scene = write_scene(tmp_path / "scene.json", request.getfixturevalue(scene_name))
    status, err = run_weft("run", scene, "--out", tmp_path / "cli", "--format", "obj,glb,pc2,usda", "--quiet")
    assert status == 0, err
    sim = weft.Simulation(scene)
    step_like_weft_run(sim, tmp_path / "py")
    frames = sorted((tmp_path / "cli" / "frames").glob("frame_*.obj"))
    assert len(frames) == len(sim.frame_times) == sim.frames_recorded == 6
    for cli_frame in frames:
        assert (tmp_path / "py" / cli_frame.name).read_bytes() == cli_frame.read_bytes(), cli_frame.name
    # The last frame's positions are the simulation's, to the OBJ's 9 decimals.
    v = np.array([[float(w) for w in line.split()[1:]] for line in frames[-1].read_text().splitlines()
                  if line.startswith("v ")])
    assert np.abs(v - sim.positions).max() <= 5e-10
    sim.write_energy_csv(tmp_path / "energy.csv")
    assert (tmp_path / "energy.csv").read_bytes() == (tmp_path / "cli" / "energy.csv").read_bytes()
    sim.write_glb(tmp_path / "animation.glb")
    sim.write_pc2(tmp_path / "animation.pc2")
    sim.write_usda(tmp_path / "animation.usda")
    for name in ["animation.glb", "animation.pc2", "animation_rest.obj", "animation.usda"]:
        assert (tmp_path / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    cli_summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    summary = sim.summary()
    for key in ["steps", "frames", "solver_iterations_total", "status", "energy_final", "kappa", "vertices"]:
        assert summary[key] == cli_summary[key], key
    assert summary["steps"] == sim.statistics["steps"] > 0
    if scene_name == "sphere":
        assert sim.statistics["contacts"] > 0
        assert summary["contacts"]["node_contacts_max"] == cli_summary["contacts"]["node_contacts_max"]


def test_steps_take_the_scenes_time_step(sheet):
    sim = weft.Simulation(sheet)
    sim.step(3)
    assert sim.statistics["steps"] == 3
    assert sim.time == pytest.approx(3 * sim.dt, rel=1e-12)
    sim.advance(0.07)
    assert sim.statistics["steps"] == 7 and sim.time == 0.07
    with pytest.raises(weft.InputError, match="before the current time"):
        sim.advance(0.05)


def test_arrays_share_memory_with_the_simulation(sheet):
    sim = weft.Simulation(sheet)
    x, v = sim.positions, sim.velocities
    assert x.shape == v.shape == (sim.vertex_count, 3) and x.dtype == np.float64
    assert np.shares_memory(x, sim.positions) and np.shares_memory(v, sim.velocities)
    assert not np.shares_memory(x, v)
    assert x.base is sim
    x0 = x.copy()
    sim.step()
    # The array fetched before the step shows the step's result.
    assert not np.array_equal(x, x0)
    assert np.array_equal(x, sim.positions) and np.array_equal(v, sim.velocities)
    free = np.setdiff1d(np.arange(sim.vertex_count), sim.pinned)
    assert np.abs(v[free]).max() > 0


def test_writing_through_the_arrays_changes_the_state(sheet):
    sim = weft.Simulation(sheet)
    m = sim.masses
    assert not m.flags.writeable and m.shape == (sim.vertex_count,)
    free = np.setdiff1d(np.arange(sim.vertex_count), sim.pinned)
    sim.velocities[free] = (0.0, 0.0, 2.0)
    assert sim.energies()["kinetic"] == pytest.approx(0.5 * 4.0 * m[free].sum(), rel=1e-12)
    gravity = sim.energies()["gravity"]
    sim.positions[:, 1] += 0.5  # everything 0.5 m higher: rigid, no elastic change
    assert sim.energies()["gravity"] - gravity == pytest.approx(9.81 * 0.5 * m.sum(), rel=1e-9)


def test_arrays_keep_the_simulation_alive(sheet):
    x = weft.Simulation(sheet).positions
    gc.collect()
    # The grid's first vertex, placed as the scene says.
    assert np.allclose(x[0], (-0.15, 1.0, 0.0), atol=1e-12)
    assert np.isfinite(x).all()


def test_energies_and_statistics(sheet):
    sim = weft.Simulation(sheet)
    e0 = sim.energies()
    assert set(e0) >= {"time", "kinetic", "elastic", "gravity", "viscous_dissipated", "numerical_dissipated",
                       "contact_work", "fail_safe_work", "total"}
    y0 = sim.positions[:, 1].copy()
    sim.step(5)
    e = sim.energies()
    assert e["time"] == sim.time
    assert e["total"] == pytest.approx(e["kinetic"] + e["elastic"] + e["gravity"], rel=1e-12, abs=1e-15)
    # Kinetic and gravitational energy from the arrays (gravity relative to the start).
    m, v = sim.masses, sim.velocities
    assert e["kinetic"] == pytest.approx(0.5 * (m[:, None] * v * v).sum(), rel=1e-12)
    assert e["gravity"] == pytest.approx(9.81 * (m * (sim.positions[:, 1] - y0)).sum(), rel=1e-9)
    assert e["gravity"] < 0 < e["kinetic"]  # falling
    # Every step statistic by its field (WEFT_STEP_STATISTICS): the counts whole numbers, the
    # largest alpha and the seconds floats.
    s = sim.statistics
    assert s["steps"] == 5 and {"newton_iterations", "newton_seconds", "guard_max_alpha"} <= set(s)
    for key, value in s.items():
        assert isinstance(value, float if key.endswith("seconds") or key == "guard_max_alpha" else int), key
    s = sim.statistics
    assert s["steps"] == 5 and s["cg_solves"] >= 5 and s["cg_iterations"] >= s["cg_solves"]


def test_energy_scale_is_weight_times_size_or_the_colliders_kinetic_energy(sheet, sphere):
    # The flat sheet at rest: its weight times its size (the diagonal of its bounding box).
    sim = weft.Simulation(sheet)
    size = np.linalg.norm(sim.positions.max(axis=0) - sim.positions.min(axis=0))
    assert sim.energy_scale == pytest.approx(sim.masses.sum() * 9.81 * size, rel=1e-9)
    # Without gravity, a sphere moving at 5 m/s: the cloth's kinetic energy at that speed.
    sphere["gravity"] = [0, 0, 0]
    sphere["colliders"][0]["motion"] = {"linear_velocity": [0, 5, 0]}
    moving = weft.Simulation(sphere)
    assert moving.energy_scale == pytest.approx(0.5 * moving.masses.sum() * 25, rel=1e-9)


def test_a_bad_scene_dict_names_the_key(sheet):
    sheet["cloth"]["mesh"]["grid"]["vertices"] = [1, 7]
    with pytest.raises(weft.InputError, match=r"cloth\.mesh\.grid\.vertices") as e:
        weft.Simulation(sheet)
    assert isinstance(e.value, ValueError)
    sheet["cloth"]["mesh"]["grid"]["vertices"] = [7, 7]
    sheet["integrator"]["colour"] = "blue"
    with pytest.raises(weft.InputError, match=r"integrator.*colour"):
        weft.Simulation(sheet)


# The keyword arguments are weft run's options: the same scene run both ways gives the same bytes,
# and a bad value gets the library's message.
def test_keyword_settings_are_weft_runs_options(tmp_path, sheet):
    scene = write_scene(tmp_path / "scene.json", sheet)
    status, err = run_weft("run", scene, "--out", tmp_path / "cli", "--method", "backward-euler", "--dt", "0.01",
                           "--duration", "0.04", "--quiet")
    assert status == 0, err
    sim = weft.Simulation(scene, method="backward-euler", dt=0.01, duration=0.04)
    assert (sim.method, sim.dt, sim.duration) == ("backward-euler", 0.01, 0.04)
    step_like_weft_run(sim, tmp_path / "py")
    frames = sorted((tmp_path / "cli" / "frames").glob("frame_*.obj"))
    assert len(frames) == len(sim.frame_times) == 3
    for cli_frame in frames:
        assert (tmp_path / "py" / cli_frame.name).read_bytes() == cli_frame.read_bytes(), cli_frame.name
    with pytest.raises(weft.InputError, match=r"^Simulation\(\): --newton 1\.5: expected an integer from 0 to 100$"):
        weft.Simulation(scene, newton=1.5)
    with pytest.raises(weft.InputError, match=r"^Simulation\(\): unknown method 'leapfrog'"):
        weft.Simulation(scene, method="leapfrog")
    with pytest.raises(TypeError):
        weft.Simulation(scene, None, "backward-euler")  # the settings are keywords only


def test_a_bad_scene_file_raises_the_message_of_weft_run(tmp_path, sheet):
    sheet["cloth"]["material"]["weft"] = -5
    scene = write_scene(tmp_path / "bad.json", sheet)
    status, err = run_weft("run", scene, "--out", tmp_path / "out")
    assert status == 2
    with pytest.raises(weft.InputError) as e:
        weft.Simulation(scene)
    assert str(e.value) in err
    assert "cloth.material" in str(e.value)
    assert err.strip() == "weft: error: " + str(e.value)


def test_moved_pins_arrive_and_stop(sheet):
    sim = weft.Simulation(sheet)
    pin, other = sim.pinned
    start, still = sim.positions[pin].copy(), sim.positions[other].copy()
    target = start + (0.05, 0.02, 0.0)
    sim.move_pins([pin], [target], over=4 * sim.dt)
    sim.step(2)
    assert np.allclose(sim.positions[pin], (start + target) / 2, atol=1e-12)
    sim.step(2)
    assert np.array_equal(sim.positions[pin], target)
    sim.step(2)
    assert np.array_equal(sim.positions[pin], target) and not sim.velocities[pin].any()
    assert np.array_equal(sim.positions[other], still)
    free = np.setdiff1d(np.arange(sim.vertex_count), sim.pinned)[0]
    with pytest.raises(weft.InputError, match=f"move_pins: vertex {free} is not pinned"):
        sim.move_pins([free], [target])
    with pytest.raises(weft.InputError, match="one position per vertex"):
        sim.move_pins([pin, other], [target])


def test_a_moved_collider_follows_the_pose_given(tmp_path, sphere):
    keyed = json.loads(json.dumps(sphere))
    sim = weft.Simulation(sphere)
    assert sim.colliders == [{"name": "colliders[0] (sphere)", "shape": "sphere"}]
    assert np.array_equal(sim.collider_pose(0), np.eye(4))
    steps = 8
    sim.move_collider(0, translation=(0.0, 0.02, 0.01), over=steps * sim.dt)
    # The same motion as the scene's keyframes: the cloth moves the same, bit for bit.
    keyed["colliders"][0]["motion"] = {"keyframes": [{"time": 0, "translation": [0, 0, 0]},
                                                      {"time": steps * sim.dt, "translation": [0, 0.02, 0.01]}]}
    reference = weft.Simulation(keyed)
    for t in sim.frame_times[1:]:
        sim.advance(t)
        reference.advance(t)
    assert np.array_equal(sim.positions, reference.positions)
    assert sim.statistics["contacts"] > 0
    assert np.allclose(sim.collider_pose(0)[:3, 3], (0.0, 0.02, 0.01), atol=1e-15)
    sim.write_collider_obj(0, tmp_path / "sphere.obj")
    v = np.array([[float(w) for w in line.split()[1:]] for line in (tmp_path / "sphere.obj").read_text().splitlines()
                  if line.startswith("v ")])
    # The sphere's surface is drawn about its moved centre.
    assert np.allclose(np.linalg.norm(v - (0.0, 0.02, 0.01), axis=1), 0.3, atol=2e-6)
    with pytest.raises(weft.InputError, match="collider 1 does not exist"):
        sim.move_collider(1, translation=(0, 0, 0))


def test_outputs_of_the_current_state(tmp_path, sheet):
    sim = weft.Simulation(sheet)
    sim.step(2)
    sim.write_obj(tmp_path / "cloth.obj")
    sim.write_ply(tmp_path / "cloth.ply")
    obj = (tmp_path / "cloth.obj").read_text().splitlines()
    assert sum(line.startswith("v ") for line in obj) == sim.vertex_count
    assert sum(line.startswith("f ") for line in obj) == len(sim.triangles)
    assert f"element vertex {sim.vertex_count}" in (tmp_path / "cloth.ply").read_text()
    with pytest.raises(weft.InputError, match="no frames recorded"):
        sim.write_glb(tmp_path / "a.glb")
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError, match="could not write"):
        sim.write_obj(tmp_path / "file" / "cloth.obj")


def test_thread_count_changes_no_bit(tmp_path):
    """A cloth settling on a sphere with self-contact on: the parallel detection gives the
    same positions on one thread and on two."""
    scene = {"weft_scene": 1, "duration": 0.05, "frame_interval": 0.05,
             "integrator": {"method": "backward-euler", "dt": 0.005},
             "cloth": {"mesh": {"grid": {"size": [0.6, 0.6], "vertices": [25, 25]}},
                       "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.3, 0.703, 0.3]},
                       "material": "cotton", "self_collision": True},
             "colliders": [{"type": "sphere", "centre": [0, 0.5, 0], "radius": 0.2}]}
    results = []
    for n in (1, 2):
        weft.set_thread_count(n)
        if n == 1:
            assert weft.thread_count() == 1
        sim = weft.Simulation(scene)
        sim.advance(0.05)
        results.append(np.array(sim.positions))
    weft.set_thread_count(0)
    assert np.array_equal(results[0], results[1])
    with pytest.raises(ValueError, match="thread count must be 0"):
        weft.set_thread_count(-1)


def test_a_new_run_shares_the_set_up_and_nothing_that_steps(sheet):
    sim = weft.Simulation(sheet, method="backward-euler")
    sim.advance(0.05)
    other = sim.new_run()
    assert other.time == 0.0 and other.method == "backward-euler"
    assert not np.shares_memory(other.positions, sim.positions)
    # It starts where the scene starts, and its own push does not reach the first run.
    fresh = weft.Simulation(sheet, method="backward-euler")
    assert np.array_equal(other.positions, fresh.positions)
    free = np.setdiff1d(np.arange(sim.vertex_count), sim.pinned)
    other.velocities[free] = (0.0, 0.0, 1.0)
    fresh.velocities[free] = (0.0, 0.0, 1.0)
    x_before = sim.positions.copy()
    other.advance(0.05)
    fresh.advance(0.05)
    assert np.array_equal(sim.positions, x_before)
    assert np.array_equal(other.positions, fresh.positions)
    assert other.summary()["steps"] == fresh.summary()["steps"] == 5


def test_runs_of_one_model_step_in_threads_as_they_do_alone(sheet):
    # advance lets go of the interpreter while it steps: two runs stepped in two threads end
    # where each ends stepped alone.
    import threading
    first = weft.Simulation(sheet)
    runs = [first.new_run(), first.new_run()]
    free = np.setdiff1d(np.arange(first.vertex_count), first.pinned)
    runs[1].velocities[free] = (0.5, 0.0, 0.0)
    threads = [threading.Thread(target=r.advance, args=(0.1,)) for r in runs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    alone = [first.new_run(), first.new_run()]
    alone[1].velocities[free] = (0.5, 0.0, 0.0)
    for r in alone:
        r.advance(0.1)
    assert runs[0].time == runs[1].time == 0.1
    assert np.array_equal(runs[0].positions, alone[0].positions)
    assert np.array_equal(runs[1].positions, alone[1].positions)
    assert not np.array_equal(runs[0].positions, runs[1].positions)
