# `weft sweep` and weft.sweep() (docs/sweeps.md) on small runs of scenes/swing.json: sweep files
# refused before anything runs, product and zip sweeps whose runs are `weft run`'s to the byte, a
# failed run as a row, an interrupted sweep resumed, and a worker killed by SIGKILL mid-run on a
# scheduler and workers started as separate processes (as on a cluster); drape experiment sweeps
# whose figures are `weft experiment drape`'s, named axes, and tools/perturb.py's sweep with the
# fail-safes' work in results.csv; temporary folders left by killed sweeps removed, and the weft
# build behind each run.
import contextlib
import csv
import hashlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
import types

import pytest

WEFT_EXE = os.environ.get("WEFT_EXE", "")
SOURCE = os.environ.get("WEFT_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
SWING = os.path.join(SOURCE, "scenes", "swing.json")

if not WEFT_EXE:
    pytest.skip("WEFT_EXE is not set (ctest sets it)", allow_module_level=True)
distributed = pytest.importorskip("distributed")
pd = pytest.importorskip("pandas")


def weft_sweep(tmp_path, spec, out, *args, timeout=120, env=None):
    """Writes `spec` as SWEEP.json and runs `weft sweep` on it; returns (exit status, stderr)."""
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(spec))
    r = subprocess.run([WEFT_EXE, "sweep", path, "--out", out, *map(str, args)], capture_output=True, text=True,
                       timeout=timeout, env=env)
    return r.returncode, r.stderr


def own_tmp(tmp_path):
    """(folder, environment) for a sweep whose temporary folders (the driver's and its local
    workers') go to a folder of the test's own."""
    tmp = tmp_path / "tmp"
    tmp.mkdir(exist_ok=True)
    return tmp, dict(os.environ, TMPDIR=str(tmp))


def sweep_temps(tmp):
    return sorted(n for n in os.listdir(tmp) if n.startswith("weft-sweep-"))


def hidden(out):
    return sorted(n for n in os.listdir(out / "runs") if n.startswith("."))


def open_text(path):
    with open(path) as f:
        return f.read()


def results(out):
    with open(os.path.join(out, "results.csv")) as f:
        return list(csv.DictReader(f))


def frames(spec):
    """Rows of a run's energy.csv: one per output frame, the first at time 0."""
    return round(spec["set"]["duration"] / 0.02) + 1


def swing_sweep(**vary):
    return {"weft_sweep": 1, "scene": SWING, "set": {"duration": 0.1}, "vary": vary}


def big_swing(duration):
    """The swing at 41 x 41 vertices: a run of about a second per simulated second on one core."""
    return {"weft_sweep": 1, "scene": SWING,
            "set": {"duration": duration, "cloth.mesh.grid.vertices": [41, 41]}}


# --- sweep files refused before anything runs ---------------------------------------------

BAD = [
    ({"vary": {"integrator.dtt": [0.01]}},
     "vary.integrator.dtt = 0.01: the scene is refused: {scene}: key integrator.dtt: unknown key"),
    ({"vary": {"integrator.dt": []}}, "vary.integrator.dt: an empty list: an axis needs one value at least"),
    ({"vary": {"integrator.dt": [0.01, -1]}},
     "vary.integrator.dt = -1: the scene is refused: {scene}: key integrator.dt: value -1.0 is out of range"),
    ({"vary": {"integrator.method": ["rk4", "nope"]}},
     "vary.integrator.method = \"nope\": the scene is refused: {scene}: key integrator.method: unknown method 'nope'"),
    ({"vary": {"integrator.dt": [0.01, 0.02], "duration": [0.1]}, "combine": "zip"},
     "vary: zipped axes must have as many values each, got integrator.dt: 2, duration: 1"),
    ({"combine": "mixed"}, "combine: must be \"product\" or \"zip\", got \"mixed\""),
    ({"vary": {"colliders[2].friction": [0.1]}}, "vary.colliders[2].friction: value 0.1: the scene has no list there"),
    ({"vary": {"cloth..material": ["cotton"]}}, "vary.cloth..material: not a key path"),
    ({"sets": {}}, "sets: unknown key"),
    ({"keep": ["movie"]}, "keep: must be a list of last_frame, frames, glb, pc2, usda, got [\"movie\"]"),
]


@pytest.mark.parametrize("change,message", BAD, ids=[m.split(":")[0] for _, m in BAD])
def test_a_bad_sweep_file_exits_2_naming_the_key_and_value_before_anything_runs(tmp_path, change, message):
    spec = {"weft_sweep": 1, "scene": SWING, "set": {"duration": 0.1}} | change
    if "colliders" in json.dumps(change):
        spec["set"]["colliders"] = {}  # not a list
    status, err = weft_sweep(tmp_path, spec, tmp_path / "out")
    assert status == 2, err
    assert err.startswith(f"weft: error: {tmp_path / 'sweep.json'}: " + message.format(scene=SWING)), err
    assert not (tmp_path / "out").exists()


def test_a_garment_panel_its_pattern_lacks_is_refused_before_anything_runs(tmp_path):
    # The scene's reader reads no pattern; the driver's scene check reads it for the panel names.
    walk = os.path.join(SOURCE, "scenes", "walk.json")
    spec = {"weft_sweep": 1, "scene": walk,
            "set": {"duration": 0.04, "cloth.mesh.pattern.panels": {"collar": {"part": "torso"}}}}
    status, err = weft_sweep(tmp_path, spec, tmp_path / "out")
    assert status == 2, err
    pattern = os.path.normpath(os.path.join(SOURCE, "data", "patterns", "coat", "coat.json"))
    assert err.startswith(f"weft: error: {tmp_path / 'sweep.json'}: set: the scene is refused: {walk}: "
                          f"key cloth.mesh.pattern.panels.collar: the pattern "), err
    assert err.rstrip().endswith("has no panel 'collar'"), err
    assert os.path.basename(pattern) in err, err
    assert not (tmp_path / "out").exists()


def test_a_missing_scene_and_a_wrong_version_are_refused(tmp_path):
    status, err = weft_sweep(tmp_path, {"weft_sweep": 1, "scene": "missing.json"}, tmp_path / "out")
    assert status == 2 and f"scene: cannot read \"missing.json\" ({tmp_path / 'missing.json'})" in err, err
    status, err = weft_sweep(tmp_path, {"weft_sweep": 2, "scene": SWING}, tmp_path / "out")
    assert status == 2 and "weft_sweep: must be 1 (the sweep format's version), got 2" in err, err


def test_a_python_without_dask_is_exit_1_naming_the_packages_and_makes_no_folder(tmp_path):
    # The interpreter without its site packages (-S) stands for one where Dask is not installed.
    python = tmp_path / "python-without-dask"
    python.write_text(f"#!/bin/sh\nexec {sys.executable} -S \"$@\"\n")
    python.chmod(0o755)
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(swing_sweep(**{"integrator.dt": [0.01]})))
    r = subprocess.run([WEFT_EXE, "sweep", path, "--out", tmp_path / "out"], capture_output=True, text=True,
                       timeout=60, env=os.environ | {"WEFT_PYTHON": str(python)})
    assert r.returncode == 1, r.stderr
    assert "weft sweep needs Dask's distributed scheduler" in r.stderr, r.stderr
    assert "apt-get install python3-distributed python3-pandas" in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


# --- runs -----------------------------------------------------------------------------------

def test_a_product_sweep_gives_one_row_per_combination_each_the_bytes_of_weft_run(tmp_path):
    methods = ["implicit-midpoint", "backward-euler", "bdf2", "implicit-midpoint-plain"]
    steps = [0.01, 0.02]
    spec = swing_sweep(**{"integrator.method": methods, "integrator.dt": steps})
    out = tmp_path / "out"
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2)
    assert status == 0, err
    assert "dashboard: " in err and "8 runs, 8 to run (0 already in" in err
    rows = results(out)
    assert [r["id"] for r in rows] == [f"{k:04d}" for k in range(8)]
    assert [(r["integrator.method"], float(r["integrator.dt"])) for r in rows] == \
        [(m, dt) for m in methods for dt in steps]
    for r in rows:
        dt = float(r["integrator.dt"])
        assert r["status"] == "ok" and r["exit_code"] == "0" and r["error"] == ""
        assert int(r["steps"]) == round(0.1 / dt)
        run = out / "runs" / r["id"]
        summary = json.loads((run / "summary.json").read_text())
        assert summary["method"] == r["integrator.method"] and summary["dt"] == dt
        # The same run by `weft run` alone: the same energies to the byte, the same figures.
        alone = tmp_path / f"alone-{r['id']}"
        subprocess.run([WEFT_EXE, "--threads", "1", "run", SWING, "--out", alone, "--duration", "0.1", "--method",
                        r["integrator.method"], "--dt", str(dt), "-q", "--no-frames"], check=True)
        assert (run / "energy.csv").read_bytes() == (alone / "energy.csv").read_bytes()
        expected = json.loads((alone / "summary.json").read_text())
        for key in ["steps", "solver_iterations_total", "energy_final", "status", "vertices"]:
            assert summary[key] == expected[key], key
        assert int(r["cg_iterations"]) == expected["solver_iterations_total"]
        assert len((run / "energy.csv").read_text().splitlines()) == frames(spec) + 1
        assert not (run / "frames").exists()  # nothing kept but summary.json and energy.csv
        record = json.loads((run / "run.json").read_text())
        assert record["params"] == {"integrator.method": r["integrator.method"], "integrator.dt": dt}
    assert not [n for n in os.listdir(out / "runs") if n.startswith(".")]  # no temporaries left


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    import logging
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=logging.ERROR)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_weft_sweep_docstring_names_every_argument_of_the_driver_with_its_default():
    import inspect
    import weft
    sys.path.insert(0, os.path.join(SOURCE, "python"))
    import weft_sweep
    for name, p in inspect.signature(weft_sweep.sweep).parameters.items():
        shown = name if p.default is inspect.Parameter.empty else f"{name}={p.default!r}"
        assert shown in weft.sweep.__doc__, shown


def test_weft_sweep_from_python_zips_axes_into_a_dataframe_with_a_failed_run_as_a_row(tmp_path, client):
    import weft
    # forward Euler at 20 ms blows up on the swing (weft run: exit status 3, unstable).
    spec = swing_sweep(**{"integrator.method": ["implicit-midpoint", "forward-euler", "backward-euler"],
                          "integrator.dt": [0.01, 0.02, 0.02]})
    spec["combine"] = "zip"
    spec["keep"] = ["last_frame", "glb"]
    spec["index"] = {"file": "index.csv", "columns": {"method": "integrator.method", "status": "status"}}
    df = weft.sweep(spec, out=tmp_path / "out", client=client)
    assert isinstance(df, pd.DataFrame)
    assert list(df["id"]) == ["0000", "0001", "0002"]
    assert list(zip(df["integrator.method"], df["integrator.dt"])) == \
        list(zip(spec["vary"]["integrator.method"], spec["vary"]["integrator.dt"]))
    assert df.attrs["runs_started"] == 3
    failed = df[df["integrator.method"] == "forward-euler"].iloc[0]
    assert failed["status"] == "unstable" and failed["exit_code"] == 3
    assert "became unstable" in failed["error"]
    for _, r in df[df["integrator.method"] != "forward-euler"].iterrows():
        assert r["status"] == "ok" and r["exit_code"] == 0 and r["error"] == ""
        kept = sorted(os.listdir(tmp_path / "out" / "runs" / r["id"] / "frames"))
        assert kept == [f"frame_{frames(spec) - 1:05d}.obj"]  # the last frame only
        assert (tmp_path / "out" / "runs" / r["id"] / "animation.glb").read_bytes()[:4] == b"glTF"
    with open(tmp_path / "out" / "index.csv") as f:
        assert list(csv.reader(f)) == [["id", "method", "status"]] + [[i, m, s] for i, m, s in
                                                                    zip(df["id"], df["integrator.method"], df["status"])]
    assert (tmp_path / "out" / "runs" / "0001" / "stderr.txt").read_text().count("unstable") >= 1
    # The client is the caller's: still usable; the same sweep again starts nothing.
    again = weft.sweep(spec, out=tmp_path / "out", client=client)
    assert again.attrs["runs_started"] == 0
    assert again.drop(columns=["run_seconds"]).equals(df.drop(columns=["run_seconds"]))
    assert client.status == "running"


def test_a_failed_run_makes_the_exit_status_7_with_every_row_written(tmp_path):
    spec = swing_sweep(**{"integrator.method": ["forward-euler", "implicit-midpoint"]})
    status, err = weft_sweep(tmp_path, spec, tmp_path / "out", "--workers", 2)
    assert status == 7, err
    assert "run 0000 (vary.integrator.method = \"forward-euler\"): unstable: weft: simulation became unstable" in err
    assert [r["status"] for r in results(tmp_path / "out")] == ["unstable", "ok"]


def finished_runs(out):
    # A run is finished once its folder is in place; a hidden .<id>.<pid>.tmp folder is one being
    # written (an interrupt may leave it), which results.csv rightly does not count.
    runs = out / "runs"
    return {n: (runs / n / "run.json").stat().st_mtime_ns for n in os.listdir(runs)
            if not n.startswith(".") and (runs / n / "run.json").exists()}


def test_an_interrupted_sweep_resumed_runs_only_the_missing_runs(tmp_path):
    spec = big_swing(0.6) | {"vary": {"cloth.material.viscosity": [0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4, 6e-4, 7e-4]}}
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "out"
    tmp, env = own_tmp(tmp_path)
    command = [WEFT_EXE, "sweep", str(path), "--out", str(out), "--workers", "2"]
    driver = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(finished_runs(out) if (out / "runs").exists() else {}) < 2:
        time.sleep(0.05)
    os.killpg(driver.pid, signal.SIGINT)  # Ctrl-C on a terminal: the driver, its workers and their runs
    err = driver.communicate(timeout=60)[1]
    assert driver.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err, err
    # The driver removed its temporary folders: no run half-written, no run's folder of its
    # workers (stopped with the cluster in mid-run).
    assert hidden(out) == [] and sweep_temps(tmp) == [], err
    before = finished_runs(out)
    assert 2 <= len(before) < 8, err
    assert len(results(out)) == len(before)
    r = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 0, r.stderr
    assert f"8 runs, {8 - len(before)} to run ({len(before)} already in" in r.stderr
    assert "removed" not in r.stderr  # nothing was left to remove
    after = finished_runs(out)
    assert len(after) == 8
    assert hidden(out) == [] and sweep_temps(tmp) == [], r.stderr
    assert {n: after[n] for n in before} == before  # the finished runs were not run again
    rows = results(out)
    assert [r["id"] for r in rows] == [f"{k:04d}" for k in range(8)] and {r["status"] for r in rows} == {"ok"}
    # Changing one axis value runs that run alone again.
    spec["vary"]["cloth.material.viscosity"][3] = 3.5e-4
    path.write_text(json.dumps(spec))
    r = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "8 runs, 1 to run (7 already in" in r.stderr, r.stderr
    assert float(results(out)[3]["cloth.material.viscosity"]) == 3.5e-4


def dead_pid():
    """The id of a process that has ended (and was reaped)."""
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def test_folders_a_killed_sweep_left_are_removed_on_resume_and_counted_only_if_their_process_is_dead(tmp_path):
    spec = swing_sweep(**{"integrator.dt": [0.01, 0.02]})
    out = tmp_path / "out"
    tmp, env = own_tmp(tmp_path)
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2, env=env)
    assert status == 0, err
    assert hidden(out) == [] and sweep_temps(tmp) == [], err  # a sweep leaves none of its own
    # As a driver and a worker killed by SIGKILL leave them: a run half-written, and a run's
    # temporary folder with its owner's file. Those of a live process, and a folder whose owner
    # is not known, are kept.
    dead, me = dead_pid(), os.getpid()
    for name in (f".0001.{dead}.tmp", f".0000.{me}.tmp"):
        (out / "runs" / name).mkdir()
        (out / "runs" / name / "summary.json").write_text("{")
    with open(f"/proc/{me}/stat") as f:
        my_start = int(f.read().rsplit(")", 1)[1].split()[19])
    for name, owner in (("weft-sweep-0001-dead", {"pid": dead, "start": None}),
                        ("weft-sweep-0001-live", {"pid": me, "start": my_start}),
                        ("weft-sweep-0001-reused", {"pid": me, "start": my_start - 1}),  # the pid given anew
                        ("weft-sweep-0001-unknown", None)):
        (tmp / name / "run").mkdir(parents=True)
        if owner:
            (tmp / name / "weft-sweep-owner.json").write_text(json.dumps(owner | {"host": socket.gethostname()}))
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2, env=env)
    assert status == 0, err
    assert (f"weft sweep: removed 1 unfinished run folders in {out / 'runs'} and 2 temporary folders in {tmp} that "
            "sweeps stopped or killed left\n") in err
    assert hidden(out) == [f".0000.{me}.tmp"]
    assert sweep_temps(tmp) == ["weft-sweep-0001-live", "weft-sweep-0001-unknown"]
    assert "all 2 runs are already in" in err


def test_leftover_tables_a_killed_driver_left_half_written_are_removed_on_resume_if_its_process_is_dead(tmp_path):
    spec = swing_sweep(**{"integrator.dt": [0.01, 0.02]})
    spec["index"] = {"file": "dataset.csv", "columns": {"status": "status"}}
    out = tmp_path / "out"
    _, env = own_tmp(tmp_path)
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2, env=env)
    assert status == 0, err
    tables = sorted(n for n in os.listdir(out) if n.endswith(".csv"))
    assert tables == ["dataset.csv", "results.csv"] and not any(n.endswith(".tmp") for n in os.listdir(out)), err
    # As a driver killed by SIGKILL while writing a table leaves it (write_csv's NAME.<pid>.tmp);
    # a live driver's, and a file of that shape that is no table of this sweep, are kept.
    dead, me = dead_pid(), os.getpid()
    planted = [f"results.csv.{dead}.tmp", f"dataset.csv.{dead}.tmp", f"results.csv.{me}.tmp", f"other.csv.{dead}.tmp"]
    for name in planted:
        (out / name).write_text("id,status\n0000,")
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2, env=env)
    assert status == 0, err
    assert f"weft sweep: removed 2 unfinished tables in {out} that sweeps stopped or killed left\n" in err
    assert sorted(n for n in os.listdir(out) if n.endswith(".tmp")) == [f"other.csv.{dead}.tmp", f"results.csv.{me}.tmp"]
    assert "all 2 runs are already in" in err
    assert [r["status"] for r in results(out)] == ["ok", "ok"]


def build_of(weft):
    """`weft --version` and the first 12 hex digits of the file's SHA-256."""
    version = subprocess.run([weft, "--version"], capture_output=True, text=True, check=True).stdout.strip()
    with open(weft, "rb") as f:
        return f"{version} sha256:{hashlib.sha256(f.read()).hexdigest()[:12]}"


def test_runs_of_another_weft_build_are_kept_and_counted_and_run_again_when_asked(tmp_path):
    spec = swing_sweep(**{"integrator.dt": [0.01, 0.02, 0.005]})
    out = tmp_path / "out"
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2)
    assert status == 0, err
    this = build_of(WEFT_EXE)
    assert [r["weft_version"] for r in results(out)] == [this] * 3
    assert json.loads((out / "runs" / "0001" / "run.json").read_text())["weft_version"] == this
    # Run 0001 as if an older build had made it.
    path = out / "runs" / "0001" / "run.json"
    record = json.loads(path.read_text())
    older = "weft 0.0.9 sha256:0123456789ab"
    record["weft_version"] = record["row"]["weft_version"] = older
    path.write_text(json.dumps(record))
    energy = (out / "runs" / "0001" / "energy.csv").stat().st_mtime_ns
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2)
    assert status == 0, err
    assert (f"weft sweep: 1 of the runs in {out} were made by another weft build than this one ({this}; "
            "results.csv's weft_version says which): kept (--rerun-other-builds") in err
    assert [r["weft_version"] for r in results(out)] == [this, older, this]
    assert (out / "runs" / "0001" / "energy.csv").stat().st_mtime_ns == energy
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2, "--rerun-other-builds")
    assert status == 0, err
    assert "run again, as asked" in err and "3 runs, 1 to run (2 already in" in err
    assert [r["weft_version"] for r in results(out)] == [this] * 3
    assert (out / "runs" / "0001" / "energy.csv").stat().st_mtime_ns != energy


# --- a worker killed mid-run, on a scheduler and workers started apart -------------------------

def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def parent(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return int(f.read().rsplit(")", 1)[1].split()[1])
    except OSError:
        return None


def weft_runs(young=None):
    """{pid: (parent pid, run id)} of the `weft run` processes of sweeps on this machine (with
    `young`, only those started less than that many seconds ago)."""
    found = {}
    with open("/proc/uptime") as f:
        uptime = float(f.read().split()[0])
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                args = f.read().split(b"\0")
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        folder = next((a.decode() for a in args if b"weft-sweep-" in a), None)
        age = uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK")
        if b"run" in args and folder and (young is None or age < young):
            found[int(pid)] = (int(fields[1]), folder.split("weft-sweep-")[1].split("-")[0])
    return found


def alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two single-threaded workers (each under its nanny) on the loopback
    address, as separate processes, the workers' temporary folders in tmp_path/tmp."""
    address = f"tcp://127.0.0.1:{free_port()}"
    python = sys.executable
    tmp, env = own_tmp(tmp_path)
    procs = [subprocess.Popen([python, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                               address.rsplit(":", 1)[1], "--no-dashboard"], stderr=subprocess.DEVNULL)]
    for _ in range(2):
        procs.append(subprocess.Popen([python, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                       "--host", "127.0.0.1", "--no-dashboard"], stderr=subprocess.DEVNULL, env=env))
    with distributed.Client(address, timeout="30s") as c:
        c.wait_for_workers(2, timeout=60)
    yield address, {p.pid for p in procs[1:]}, tmp
    for p in reversed(procs):
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


@contextlib.contextmanager
def stderr_shown_on_failure(driver):
    """On a failed assertion (or any error) in the block, the driver is stopped and what it wrote
    on standard error (err.text, or what is left to read) goes with the failure."""
    err = types.SimpleNamespace(text="")
    try:
        yield err
    except BaseException as e:
        if driver.poll() is None:
            driver.kill()
        try:
            err.text = err.text or driver.communicate(timeout=10)[1]
        except (subprocess.TimeoutExpired, ValueError, OSError):
            pass
        raise AssertionError(f"{type(e).__name__}: {e}\n--- weft sweep's standard error ---\n{err.text}") from e


def test_a_worker_killed_mid_run_has_its_run_retried_and_every_row_present(tmp_path, cluster):
    spec = big_swing(1.0) | {"vary": {"integrator.method": ["implicit-midpoint", "backward-euler", "bdf2"],
                                      "integrator.dt": [0.01, 0.02]}}
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "out"
    address, nannies, tmp = cluster
    driver = subprocess.Popen([WEFT_EXE, "sweep", str(path), "--out", str(out), "--scheduler", address],
                              stderr=subprocess.PIPE, text=True)
    with stderr_shown_on_failure(driver) as err:
        killed_worker_checks(driver, spec, tmp_path, out, nannies, tmp, err)


def killed_worker_checks(driver, spec, tmp_path, out, nannies, tmp, err):
    deadline = time.monotonic() + 60
    victim = None
    while victim is None and time.monotonic() < deadline and driver.poll() is None:
        # This cluster's (the run's worker a child of one of its nannies), and just started, so
        # that it is still running when its worker is killed (a run takes about a second).
        runs = weft_runs(young=0.3)
        victim = next(((pid, ppid, run_id) for pid, (ppid, run_id) in runs.items() if parent(ppid) in nannies), None)
        time.sleep(0.02)
    assert victim is not None, "no run was seen running"
    run_pid, worker_pid, run_id = victim
    os.kill(worker_pid, signal.SIGKILL)
    err.text = driver.communicate(timeout=120)[1]
    assert driver.returncode == 0
    rows = results(out)
    assert sorted(r["id"] for r in rows) == [f"{k:04d}" for k in range(6)]  # every row, none twice
    assert {r["status"] for r in rows} == {"ok"}
    # The killed run's process did not outlive its worker, and the run was done again elsewhere,
    # in full: its energies are those of `weft run` of its scene.
    deadline = time.monotonic() + 10
    while alive(run_pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(run_pid)
    run = out / "runs" / run_id
    record = json.loads((run / "run.json").read_text())
    assert record["worker_pid"] != worker_pid
    alone = tmp_path / "alone"
    subprocess.run([WEFT_EXE, "--threads", "1", "run", run / "scene.json", "--out", alone, "-q", "--no-frames"],
                   check=True)
    assert (run / "energy.csv").read_bytes() == (alone / "energy.csv").read_bytes()
    assert len((run / "energy.csv").read_text().splitlines()) == frames(spec) + 1
    # The killed worker's folder for its run was removed by a worker once it was seen dead.
    assert sweep_temps(tmp) == []


def test_a_random_axis_moves_by_at_most_its_size_the_same_for_a_seed_every_time():
    sys.path.insert(0, os.path.join(SOURCE, "python"))
    from weft_sweep import load
    spec = swing_sweep(**{"cloth.placement.translation": {"random": {"seeds": 3, "size": 0.001}},
                          "integrator.dt": [0.01, 0.02]})
    runs = load(spec).runs
    base = json.loads(open_text(SWING))["cloth"]["placement"]["translation"]
    moved = {}
    for r in runs:
        seed = r.params["cloth.placement.translation"]
        t = r.scene["cloth"]["placement"]["translation"]
        assert all(abs(a - b) <= 0.001 for a, b in zip(t, base)) and t != base
        assert moved.setdefault(seed, t) == t  # one seed, one placement, whatever the other axes
    assert sorted(moved) == [0, 1, 2] and len({json.dumps(t) for t in moved.values()}) == 3
    assert [r.scene["cloth"]["placement"]["translation"] for r in load(spec).runs] == \
        [r.scene["cloth"]["placement"]["translation"] for r in runs]


# --- experiment sweeps: weft experiment drape in place of weft run -----------------------------

def drape_sweep(**change):
    """Drapes at 3 cm triangles for 0.3 s of simulated time: a tenth of a second a run."""
    return {"weft_sweep": 1, "experiment": "drape", "set": {"edge_length": 0.03, "max_time": 0.3}} | change


def test_a_drape_sweep_gives_each_run_the_figures_of_weft_experiment_drape_alone(tmp_path):
    fabric = os.path.join(SOURCE, "data", "fabrics", "matsudaira", "matsudaira-polyester-faille.json")
    spec = drape_sweep(vary={"material": ["silk", fabric], "specimen_diameter": [0.30, 0.36]},
                       index={"file": "drape.csv", "columns": {"fabric": "material", "dc": "drape_coefficient"}})
    out = tmp_path / "out"
    status, err = weft_sweep(tmp_path, spec, out, "--workers", 2)
    assert status == 0, err
    rows = results(out)
    assert [(r["material"], float(r["specimen_diameter"])) for r in rows] == \
        [(m, d) for m in ["silk", fabric] for d in [0.30, 0.36]]
    for r in rows:
        assert r["status"] == "ok" and r["exit_code"] == "0" and r["error"] == ""
        alone = tmp_path / f"alone-{r['id']}"
        subprocess.run([WEFT_EXE, "--threads", "1", "experiment", "drape", "--material", r["material"],
                        "--specimen-diameter", r["specimen_diameter"], "--edge-length", "0.03", "--max-time", "0.3",
                        "--out", alone, "-q", "--no-pictures"], check=True, capture_output=True)
        expected = json.loads((alone / "results.json").read_text())
        run = out / "runs" / r["id"]
        kept = json.loads((run / "results.json").read_text())
        assert {k: v for k, v in kept.items() if k != "wall_seconds"} == \
            {k: v for k, v in expected.items() if k != "wall_seconds"}
        # results.csv's figures are results.json's, written back to the same number.
        assert float(r["drape_coefficient"]) == expected["drape_coefficient"]
        assert int(r["nodes"]) == expected["nodes"] and r["at_rest"] == str(expected["at_rest"])
        assert int(r["vertices"]) == expected["vertices"] and int(r["steps"]) == expected["steps"]
        assert (run / "edge.csv").read_bytes() == (alone / "edge.csv").read_bytes()
        assert not (run / "top.png").exists()  # pictures only when "keep" asks for them
        assert json.loads((run / "experiment.json").read_text())["options"]["specimen_diameter"] == \
            float(r["specimen_diameter"])
    with open(out / "drape.csv") as f:
        assert list(csv.reader(f)) == [["id", "fabric", "dc"]] + [[r["id"], r["material"], r["drape_coefficient"]]
                                                                  for r in rows]


BAD_EXPERIMENTS = [
    ({"vary": {"specimen_diameter": [0.30, 0.24]}},
     "vary.specimen_diameter = 0.24: weft experiment drape refuses it: --edge-length 0.03: expected a positive "
     "length (m) at most half the overhang (0.015 m)"),
    ({"vary": {"material": ["cotton", "no-such-fabric"]}},
     "vary.material = \"no-such-fabric\": weft experiment drape refuses it: --material 'no-such-fabric': unknown "
     "material preset"),
    ({"vary": {"dt": [0.005, 0.5]}},
     "vary.dt = 0.5: weft experiment drape refuses it: --dt 0.5: expected a positive step (s) at most 0.05"),
    ({"vary": {"max_time": [0.3, -1]}},
     "vary.max_time = -1: weft experiment drape refuses it: --max-time -1: expected a positive time (s)"),
    ({"vary": {"spin": [1, 2]}},
     "vary.spin = 1: weft experiment drape refuses it: The following arguments were not expected: 1 --spin"),
    ({"vary": {"out": ["a"]}}, "vary.out: --out is the sweep's own to give"),
    ({"vary": {"grain_deg": {"add": [0, 45]}}}, "vary.grain_deg: an experiment's axis is a list of values"),
    ({"vary": {"edge-length": [0.03]}}, "vary.edge-length: not an option of weft experiment drape"),
    ({"set": {"edge_length": [0.03]}}, "set.edge_length: an experiment's option takes a number, a string or "
                                       "true/false, got [0.03]"),
    ({"experiment": "tensile"}, "experiment: must be one of drape (the experiments a sweep runs), got \"tensile\""),
    ({"scene": "scenes/swing.json"}, "scene: an experiment sweep has no scene"),
    ({"keep": ["glb"]}, "keep: must be a list of pictures, got [\"glb\"]"),
]


@pytest.mark.parametrize("change,message", BAD_EXPERIMENTS, ids=[m.split(":")[0] for _, m in BAD_EXPERIMENTS])
def test_a_bad_experiment_sweep_exits_2_naming_the_key_and_value_before_anything_runs(tmp_path, change, message):
    status, err = weft_sweep(tmp_path, drape_sweep(**change), tmp_path / "out")
    assert status == 2, err
    assert err.startswith(f"weft: error: {tmp_path / 'sweep.json'}: " + message), err
    assert not (tmp_path / "out").exists()


def test_a_named_axis_sets_several_keys_and_its_column_holds_the_name():
    sys.path.insert(0, os.path.join(SOURCE, "python"))
    from weft_sweep import load
    spec = swing_sweep(**{"pace": {"named": {"fine": {"integrator.dt": 0.005, "integrator.method": "bdf2"},
                                             "coarse": {"integrator.dt": 0.02}}},
                          "cloth.material": ["cotton", "silk"]})
    runs = load(spec).runs
    assert [r.params for r in runs] == [{"pace": p, "cloth.material": m} for p in ["fine", "coarse"]
                                        for m in ["cotton", "silk"]]
    base = json.loads(open_text(SWING))["integrator"]
    for r in runs:
        fine = r.params["pace"] == "fine"
        assert r.scene["integrator"]["dt"] == (0.005 if fine else 0.02)
        assert r.scene["integrator"]["method"] == ("bdf2" if fine else base["method"])
        assert "pace" not in r.scene  # the name is the column's, not a key of the scene


# --- tools/perturb.py: a sweep of a scene and its changed copies --------------------------------

def test_perturb_py_runs_its_variations_as_a_sweep_with_the_fail_safes_work_in_results_csv(tmp_path):
    scene = os.path.join(SOURCE, "scenes", "spinning-sphere.json")
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, os.path.join(SOURCE, "tools", "perturb.py"), scene, "--out", out,
                        "--duration", "0.12", "--jobs", "2", "--weft", WEFT_EXE], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    spec = json.loads((out / "perturb.json").read_text())
    names = ["as-shipped", "shift+x", "shift-x", "shift+y", "shift+z", "friction"]
    assert list(spec["vary"]["variation"]["named"]) == names
    base = json.loads(open_text(scene))
    rows = results(out)
    assert [row["variation"] for row in rows] == names
    table = r.stdout.splitlines()
    for row in rows:
        run = out / "runs" / row["id"]
        summary = json.loads((run / "summary.json").read_text())
        ran = json.loads((run / "scene.json").read_text())
        moved = [a - b for a, b in zip(ran["cloth"]["placement"]["translation"], base["cloth"]["placement"]["translation"])]
        assert sum(abs(m) for m in moved) == pytest.approx(0 if row["variation"] in ("as-shipped", "friction") else 0.001)
        assert ran["colliders"][0]["friction"] == pytest.approx(base["colliders"][0]["friction"] -
                                                                 (0.01 if row["variation"] == "friction" else 0))
        # results.csv's fail-safe figures are the run's summary's; clear is ok with no pair.
        assert float(row["fail_safe_work_J"]) == summary["contacts"]["fail_safe_work_J"]
        assert int(row["fail_safe_moves"]) == summary["contacts"]["fail_safe_moves"]
        assert int(row["halved_steps"]) == summary["contacts"]["halved_steps"]
        assert row["clear"] == str(summary["status"] == "ok" and summary["intersections"]["total"] == 0)
        assert sum(1 for line in table if line.startswith("| ") and f"| {row['fail_safe_moves']} | " in line) >= 1
    assert (out / "results.md").read_text() == r.stdout
