"""What a Dask worker does for one run: `weft run` (or `weft experiment NAME`) in a fresh
temporary folder, in its own process, and the run's outputs returned as bytes (no shared file
system needed).

This module is sent to the workers by value (cloudpickle), so a worker needs only Python with
Dask and the `weft` command, not weft's Python files. It imports nothing from weft_sweep.
"""
import os
import shutil
import socket
import subprocess
import tempfile
import time

STDERR_KEPT = 4000  # the last characters of a run's standard error kept in its task result


def _die_with_parent():
    """The command's prefix that makes the run's process end when the worker that started it
    does (a worker killed mid-run leaves no orphan simulating on): util-linux's setpriv, which
    sets prctl(PR_SET_PDEATHSIG, SIGKILL) and execs the run. (Not a preexec_fn, which is unsafe
    in a worker's threads and makes every start a full fork.)"""
    setpriv = shutil.which("setpriv")
    return [setpriv, "--pdeathsig", "KILL"] if setpriv else []


def _outputs(folder, keep):
    """The files of a finished run that go back to the driver: summary.json, energy.csv and
    what `keep` asks for; every file of an experiment's (keep "all")."""
    if keep == "all":
        return {os.path.relpath(os.path.join(d, n), folder): _read(os.path.join(d, n))
                for d, _, files in os.walk(folder) for n in files}
    names = ["summary.json", "energy.csv"]
    for k, files in (("glb", ["animation.glb"]), ("pc2", ["animation.pc2", "animation_rest.obj"]),
                     ("usda", ["animation.usda"])):
        if k in keep:
            names += files
    frames_dir = os.path.join(folder, "frames")
    frames = sorted(os.listdir(frames_dir)) if os.path.isdir(frames_dir) else []
    if "frames" in keep:
        names += [os.path.join("frames", f) for f in frames]
    elif "last_frame" in keep:
        cloth = [f for f in frames if f.startswith("frame_")]
        if cloth:
            number = cloth[-1][len("frame_"):]
            names += [os.path.join("frames", f) for f in frames if f.endswith("_" + number)]
    return {name: _read(os.path.join(folder, name)) for name in names if os.path.isfile(os.path.join(folder, name))}


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def run_one(task, files):
    """Runs `weft --threads T` with task["argv"] in a temporary folder holding `files` ({name:
    bytes}) in files/ and task["scene_text"] (if any) as scene.json ("{scene}" and "{out}" in the
    arguments are their paths); returns a dict: id, hash, exit_code, stderr, seconds, host,
    outputs {relative path: bytes}, error (when weft could not be started)."""
    result = {"id": task["id"], "hash": task["hash"], "host": socket.gethostname(), "pid": os.getpid(),
              "exit_code": None, "stderr": "", "error": "", "outputs": {}, "timed_out": False}
    weft = os.environ.get("WEFT_EXE") or task["weft"]
    start = time.monotonic()
    folder = tempfile.mkdtemp(prefix=f"weft-sweep-{task['id']}-")
    try:
        for name, data in files.items():
            path = os.path.join(folder, "files", name)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
        scene = os.path.join(folder, "scene.json")
        if task.get("scene_text") is not None:
            with open(scene, "w") as f:
                f.write(task["scene_text"])
        out = os.path.join(folder, "run")
        places = {"{scene}": scene, "{out}": out}
        command = _die_with_parent() + [weft, "--threads", str(task["threads"])] + [places.get(a, a) for a in task["argv"]]
        try:
            proc = subprocess.run(command, cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  timeout=task["timeout"])
            result["exit_code"] = proc.returncode
            result["stderr"] = proc.stderr.decode(errors="replace")[-STDERR_KEPT:]
        except subprocess.TimeoutExpired as e:
            result["timed_out"] = True
            result["stderr"] = (e.stderr or b"").decode(errors="replace")[-STDERR_KEPT:]
        except OSError as e:
            result["error"] = f"could not start {weft} on {result['host']}: {e.strerror}"
        if os.path.isdir(out):
            result["outputs"] = _outputs(out, task["keep"])
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    result["seconds"] = time.monotonic() - start
    return result
