"""What a Dask worker does for one run: `weft run` (or `weft experiment NAME`) in a fresh
temporary folder, in its own process, and the run's outputs returned as bytes (no shared file
system needed).

This module is sent to the workers by value (cloudpickle), so a worker needs only Python with
Dask and the `weft` command, not weft's Python files. It imports nothing from weft_sweep.
"""
import hashlib
import json
import os
import shutil
import socket
import subprocess
import tempfile
import time

STDERR_KEPT = 4000  # the last characters of a run's standard error kept in its task result
OWNER = "weft-sweep-owner.json"  # in each temporary folder: the process that made it


def _stat(pid):
    """(state, start in clock ticks after boot) of process `pid` from /proc/PID/stat, None if
    there is no such process (or no /proc)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return fields[0], int(fields[19])
    except (OSError, ValueError, IndexError):
        return None


def process_start(pid):
    stat = _stat(pid)
    return stat[1] if stat else None


def alive(pid, start=None):
    """Whether process `pid` is running (not a zombie and, given `start`, the one that started
    then, not a later process given the same number)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    stat = _stat(pid)
    if stat is None:  # gone since, or no /proc to ask (then kill's answer)
        return not os.path.exists("/proc/self/stat")
    return stat[0] != "Z" and (start is None or stat[1] == start)


def make_temp(prefix):
    """A temporary folder holding OWNER: this process's id, start and host, by which
    remove_stale() knows it for a sweep's own once this process is gone."""
    folder = tempfile.mkdtemp(prefix=prefix)
    with open(os.path.join(folder, OWNER), "w") as f:
        json.dump({"pid": os.getpid(), "start": process_start(os.getpid()), "host": socket.gethostname()}, f)
    return folder


def remove_stale(tmp=None):
    """Removes the folders weft-sweep-* in `tmp` (default: the temporary folder) that a sweep's
    process on this host made (OWNER) and that outlived it (killed before it cleaned up);
    returns how many. Folders without OWNER, or of a live process or another host, are left."""
    tmp = tmp or tempfile.gettempdir()
    host, removed = socket.gethostname(), 0
    try:
        names = [n for n in os.listdir(tmp) if n.startswith("weft-sweep-")]
    except OSError:
        return 0
    for name in names:
        folder = os.path.join(tmp, name)
        try:
            with open(os.path.join(folder, OWNER)) as f:
                owner = json.load(f)
            pid, start = int(owner["pid"]), owner.get("start")
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if owner.get("host") == host and not alive(pid, start):
            shutil.rmtree(folder, ignore_errors=True)
            removed += not os.path.exists(folder)
    return removed


def build_identity(weft):
    """The build of the weft command at `weft`: `weft --version` and the first 12 hex digits of
    the file's SHA-256 ("weft 0.1.0 sha256:0123456789ab"); the version alone names no build."""
    digest = hashlib.sha256()
    with open(weft, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    proc = subprocess.run([weft, "--version"], capture_output=True, text=True)
    version = proc.stdout.strip() or f"weft (--version: exit status {proc.returncode})"
    return f"{version} sha256:{digest.hexdigest()[:12]}"


def _file_key(path):
    st = os.stat(path)
    return [os.path.realpath(path), st.st_size, st.st_mtime_ns]


def _build_of(weft, known):
    """build_identity(weft), taken from `known` ({"key": _file_key, "id": identity}, the
    driver's) when it names this very file unchanged; None if weft cannot be read."""
    try:
        if known and _file_key(weft) == known.get("key"):
            return known["id"]
        return build_identity(weft)
    except OSError:
        return None


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
    outputs {relative path: bytes}, error (when weft could not be started), weft_version (the
    build run, task["build"]'s when the same file) and stale_removed (remove_stale's count)."""
    result = {"id": task["id"], "hash": task["hash"], "host": socket.gethostname(), "pid": os.getpid(),
              "exit_code": None, "stderr": "", "error": "", "outputs": {}, "timed_out": False}
    weft = os.environ.get("WEFT_EXE") or task["weft"]
    result["weft_version"] = _build_of(weft, task.get("build"))
    result["stale_removed"] = remove_stale()  # folders of this host's runs whose worker was killed
    start = time.monotonic()
    folder = make_temp(f"weft-sweep-{task['id']}-")
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
