"""The sweep's driver: checks every run's scene, hands the runs to Dask, writes what comes back
(docs/sweeps.md).

Each run's outputs are written to OUT/runs/<id>/ under a temporary name (.<id>.<pid>.tmp) and
renamed into place, run.json last, so a folder runs/<id>/ with a run.json is a finished run; a
later sweep into the same OUT skips those whose scene is unchanged (its hash in run.json), and
names those that another weft build made (its weft_version in run.json).
"""
import csv
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor

from . import worker
from .spec import EXPERIMENTS, SweepError

OK_STATUSES = ("ok", "solver_capped")
ENERGIES = ("kinetic", "elastic", "gravity", "viscous_dissipated", "numerical_dissipated")
EXIT_SOME_FAILED = 7
EXIT_OUTPUT_FAILED = 4
EXIT_INTERRUPTED = 130


class OutputError(Exception):
    """An output of the sweep could not be written; the message names it."""


class DaskMissing(Exception):
    pass


def import_dask():
    try:
        import distributed  # noqa: F401
    except ImportError as e:
        raise DaskMissing(f"weft sweep needs Dask's distributed scheduler for {sys.executable} ({e}); on Debian: "
                          "apt-get install python3-distributed python3-pandas")
    return distributed


def find_weft(weft=None):
    """The `weft` command the runs use: `weft`, else $WEFT_EXE, else `weft` on the PATH."""
    weft = weft or os.environ.get("WEFT_EXE") or shutil.which("weft")
    if not weft or not os.path.isfile(weft):
        raise SweepError(f"no weft command at {weft!r} (give weft=PATH or set WEFT_EXE)" if weft else
                         "no weft command found (give weft=PATH, set WEFT_EXE or put weft on the PATH)")
    return os.path.abspath(weft)


def check_scenes(sw, weft):
    """Every run's scene through the library's own checks (`weft sweep --check-scenes`):
    raises SweepError naming the sweep's key and value behind the first refused one."""
    items = [{"scene": r.scene, "name": sw.scene_file, "base_dir": sw.scene_dir} for r in sw.runs]
    tmp = worker.make_temp("weft-sweep-check-")
    try:
        path = os.path.join(tmp, "scenes.json")
        with open(path, "w") as f:
            json.dump(items, f)
        proc = subprocess.run([weft, "sweep", "--check-scenes", path], capture_output=True, text=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if proc.returncode != 0:
        raise SweepError(f"{sw.name}: checking the runs' scenes failed: {proc.stderr.strip()}")
    refused = json.loads(proc.stdout)
    if refused:
        first = sw.runs[refused[0]["index"]]
        more = f" ({len(refused)} of {len(sw.runs)} runs refused)" if len(refused) > 1 else ""
        raise SweepError(f"{sw.name}: {sw.culprit(first)}: the scene is refused: {refused[0]['error']}{more}")


def experiment_argv(name, options):
    """`weft experiment NAME`'s arguments for a run's options: {"specimen_diameter": 0.24,
    "self_collision": true} -> --specimen-diameter 0.24 --self-collision (false: the flag left out)."""
    argv = ["experiment", name]
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is True:
            argv.append(flag)
        elif value is not False:
            argv += [flag, value if isinstance(value, str) else json.dumps(value)]
    return argv


def _probe(options):
    """A drape run's options cut to one time step: every option still goes through the
    experiment's own checks (a --max-time that is not a positive number is left to them)."""
    probe = dict(options)
    dt = options.get("dt", 0.005)
    dt = dt if isinstance(dt, (int, float)) and not isinstance(dt, bool) and dt > 0 else 0.005
    limit = options.get("max_time", dt)
    if isinstance(limit, (int, float)) and not isinstance(limit, bool) and limit > 0:
        probe["max_time"] = min(limit, dt)
    return probe


def check_experiments(sw, weft):
    """Every run's options through the experiment's own checks before anything runs: `weft
    experiment NAME` of each distinct set of options cut to one time step, in a temporary folder
    (exit status 2: refused). Raises SweepError naming the sweep's key and value behind the
    first refused run."""
    def probe(run):
        tmp = worker.make_temp("weft-sweep-check-")
        try:
            argv = experiment_argv(sw.experiment, _probe(run.scene)) + ["--out", os.path.join(tmp, "out"), "-q",
                                                                         "--no-pictures"]
            proc = subprocess.run([weft, "--threads", "1", *argv], capture_output=True, text=True, cwd=sw.base_dir)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        lines = [l for l in proc.stderr.splitlines() if l.strip()]
        said = lines[0].removeprefix("weft: error: ") if lines else f"exit status {proc.returncode}"
        return said if proc.returncode == 2 else None

    distinct = {}
    for r in sw.runs:
        distinct.setdefault(r.hash, r)
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        refused = {h: e for h, e in zip(distinct, pool.map(probe, distinct.values())) if e}
    bad = [r for r in sw.runs if r.hash in refused]
    if bad:
        more = f" ({len(bad)} of {len(sw.runs)} runs refused)" if len(bad) > 1 else ""
        raise SweepError(f"{sw.name}: {sw.culprit(bad[0])}: weft experiment {sw.experiment} refuses it: "
                         f"{refused[bad[0].hash]}{more}")


def shipped_files(sw):
    """The files the runs' scenes name (absolute paths of existing files) go to the workers
    with the task: {path: name under the run's files/ folder}."""
    names = {}

    def walk(value):
        if isinstance(value, dict):
            for v in value.values():
                walk(v)
        elif isinstance(value, list):
            for v in value:
                walk(v)
        elif isinstance(value, str) and os.path.isabs(value) and os.path.isfile(value) and value not in names:
            names[value] = f"{len(names)}/{os.path.basename(value)}"

    for r in sw.runs:
        walk(r.scene)
    return names


def relocated(value, names):
    if isinstance(value, dict):
        return {k: relocated(v, names) for k, v in value.items()}
    if isinstance(value, list):
        return [relocated(v, names) for v in value]
    if isinstance(value, str) and value in names:
        return "files/" + names[value]
    return value


def run_arguments(keep):
    """`weft run`'s options for what a sweep keeps: OBJ frames only when frames are kept."""
    formats = [k for k in ("glb", "pc2", "usda") if k in keep]
    frames = "frames" in keep or "last_frame" in keep
    if frames:
        formats.insert(0, "obj")
    args = ["--format", ",".join(formats)] if formats else []
    return args + ([] if frames else ["--no-frames"])


def task_command(sw, run, names):
    """(arguments after `weft --threads T`, scene text or None) of a run's task."""
    if sw.experiment:
        argv = experiment_argv(sw.experiment, relocated(run.scene, names)) + ["--out", "{out}", "-q"]
        return argv + ([] if "pictures" in sw.keep else ["--no-pictures"]), None
    return ["run", "-q", "{scene}", "--out", "{out}"] + run_arguments(sw.keep), json.dumps(relocated(run.scene, names))


def status_of(result, summary):
    """(status, error) of a run from its task's result."""
    stderr = result.get("stderr", "")
    lines = [l for l in stderr.splitlines() if l.strip()]
    said = next((l for l in reversed(lines) if l.startswith("weft: error:") or l.startswith("weft: simulation")),
                lines[-1] if lines else "")
    if result.get("error"):
        return "error", result["error"]
    if result.get("timed_out"):
        return "timeout", f"stopped after the sweep's timeout of {result.get('timeout')} s"
    code = result["exit_code"]
    if result.get("experiment"):
        if code == 0 and summary is not None:
            return "ok", ""
        if code == 3:
            return "unstable", said
    elif summary is not None and code in (0, 3, 4, 5, 130):  # 5: finished with crossed frames (counted)
        status = summary.get("status", "?")
        return status, ("" if status in OK_STATUSES else said)
    if code is not None and code < 0:
        return "failed", f"killed by signal {-code}" + (f": {said}" if said else "")
    return "failed", said or f"exit status {code}"


def row_of(run, result, summary, status, error):
    row = {"id": run.id, **{k: json.dumps(v) if isinstance(v, (list, dict)) else v for k, v in run.params.items()},
           "status": status, "exit_code": result.get("exit_code"), "error": error}
    s = summary or {}
    if run.experiment:  # the experiment's figures, from its results.json
        for k in EXPERIMENTS[run.experiment]["figures"]:
            row[k] = s.get(k)
        row["run_seconds"] = round(result["seconds"], 3)
        row["host"] = result.get("host")
        row["weft_version"] = result.get("weft_version")
        return row
    inter = s.get("intersections")
    row.update({
        "steps": s.get("steps"), "wall_seconds": s.get("wall_seconds"), "run_seconds": round(result["seconds"], 3),
        "cg_iterations": s.get("solver_iterations_total"),
        "intersections": inter.get("total") if isinstance(inter, dict) else inter,
        "vertices": s.get("vertices"),
    })
    energy = s.get("energy_final") or {}
    for e in ENERGIES:
        row[f"energy_{e}"] = energy.get(e)
    # The contact fail-safes' work and moves, the steps halved and the guard's parts per step
    # (tools/perturb.py's table), and whether the run ended ok with no intersecting pair.
    contacts = s.get("contacts") or {}
    row.update({"fail_safe_work_J": contacts.get("fail_safe_work_J"), "fail_safe_moves": contacts.get("fail_safe_moves"),
                "halved_steps": contacts.get("halved_steps"),
                "guard_parts_per_step": (s.get("guard") or {}).get("parts_per_step")})
    row["clear"] = None if summary is None else status == "ok" and row["intersections"] == 0
    row["host"] = result.get("host")
    row["weft_version"] = result.get("weft_version")
    return row


class RunFolders:
    """OUT/runs/<id>/: written whole under a temporary name, then renamed into place."""

    def __init__(self, out):
        self.root = os.path.join(out, "runs")
        try:
            os.makedirs(self.root, exist_ok=True)
        except OSError as e:
            raise OutputError(f"cannot create {self.root}: {e.strerror}")
        self.stale_removed = self.remove_stale()

    def remove_stale(self):
        """Removes the folders .<id>.<pid>.tmp (and .old) that a driver killed while writing left
        (its pid no longer running; those of a live driver writing into the same OUT are left);
        returns how many."""
        removed = 0
        for name in os.listdir(self.root):
            parts = name.split(".")
            if len(parts) == 4 and parts[0] == "" and parts[3] in ("tmp", "old") and parts[2].isdigit() \
                    and not worker.alive(int(parts[2])):
                path = os.path.join(self.root, name)
                shutil.rmtree(path, ignore_errors=True)
                removed += not os.path.exists(path)
        return removed

    def finished(self, run):
        """run.json's record when runs/<id>/ holds this run (same scene hash), else None."""
        try:
            with open(os.path.join(self.root, run.id, "run.json")) as f:
                record = json.load(f)
        except (OSError, ValueError):
            return None
        return record if record.get("hash") == run.hash else None

    def write(self, run, result, row):
        final = os.path.join(self.root, run.id)
        tmp = os.path.join(self.root, f".{run.id}.{os.getpid()}.tmp")
        old = os.path.join(self.root, f".{run.id}.{os.getpid()}.old")
        try:
            shutil.rmtree(tmp, ignore_errors=True)
            os.makedirs(tmp)
            files = dict(result["outputs"])
            if run.experiment:
                files["experiment.json"] = (json.dumps({"experiment": run.experiment, "options": run.scene}, indent=1)
                                            + "\n").encode()
            else:
                files["scene.json"] = (json.dumps(run.scene, indent=1) + "\n").encode()
            if result.get("stderr"):
                files["stderr.txt"] = result["stderr"].encode()
            for name, data in files.items():
                path = os.path.join(tmp, name)
                os.makedirs(os.path.dirname(path), exist_ok=True)
                with open(path, "wb") as f:
                    f.write(data)
            record = {"id": run.id, "hash": run.hash, "params": run.params, "row": row, "finished": time.time(),
                      "worker_pid": result.get("pid"), "weft_version": result.get("weft_version")}
            with open(os.path.join(tmp, "run.json"), "w") as f:
                json.dump(record, f, indent=1)
                f.write("\n")
            if os.path.exists(final):
                os.rename(final, old)
            os.rename(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        except OSError as e:
            self._undo(final, tmp, old)
            raise OutputError(f"could not write {e.filename or tmp}: {e.strerror}; the runs finished before are kept "
                              f"in {self.root}")
        except BaseException:  # Ctrl-C while writing: the run is not in, and nothing half-written is left
            self._undo(final, tmp, old)
            raise

    @staticmethod
    def _undo(final, tmp, old):
        if os.path.exists(old) and not os.path.exists(final):
            os.rename(old, final)
        shutil.rmtree(tmp, ignore_errors=True)


def write_csv(path, rows, columns=None):
    columns = columns or list(dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: "" if r.get(k) is None else r.get(k) for k in columns})
    tmp = f"{path}.{os.getpid()}.tmp"
    try:
        with open(tmp, "w") as f:
            f.write(buf.getvalue())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.remove(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise OutputError(f"could not write {path}: {e.strerror}")
        raise


def table_names(sw):
    """The tables a sweep writes into OUT: results.csv and the index file, if any."""
    return ["results.csv"] + ([sw.index["file"]] if sw.index else [])


def remove_stale_tables(out, names):
    """Removes the files NAME.<pid>.tmp (write_csv's) of the tables `names` that a driver killed
    while writing one left in `out` (its pid no longer running; a live driver's are left);
    returns how many."""
    removed = 0
    for entry in os.listdir(out):
        table, _, pid = entry.removesuffix(".tmp").rpartition(".")
        if entry.endswith(".tmp") and table in names and pid.isdigit() and not worker.alive(int(pid)):
            path = os.path.join(out, entry)
            try:
                os.remove(path)
                removed += 1
            except OSError:
                pass
    return removed


def write_tables(sw, out, rows):
    rows = sorted(rows, key=lambda r: r["id"])
    write_csv(os.path.join(out, "results.csv"), rows)
    if sw.index:
        columns = sw.index.get("columns") or {}
        index_rows = [{name: r.get(what) for name, what in columns.items()} | {"id": r["id"]} for r in rows]
        write_csv(os.path.join(out, sw.index["file"]), index_rows, ["id", *columns])
    return rows


class Progress:
    """Runs done, running and failed, and the time left, on standard error: one line redrawn on a
    terminal, a line every 10 s otherwise."""

    def __init__(self, total, skipped, quiet, stream=None):
        self.stream = stream or sys.stderr
        self.total, self.skipped, self.quiet = total, skipped, quiet
        self.done = skipped
        self.failed = 0
        self.running = 0
        self.start = time.monotonic()
        self.last = 0.0
        self.tty = self.stream.isatty()

    def line(self):
        fresh = self.done - self.skipped
        left = self.total - self.done
        elapsed = time.monotonic() - self.start
        eta = f", about {left * elapsed / fresh:.0f} s left" if fresh and left else ""
        return f"weft sweep: {self.done}/{self.total} done, {self.running} running, {self.failed} failed{eta}"

    def show(self, force=False):
        if self.quiet:
            return
        now = time.monotonic()
        if self.tty:
            if force or now - self.last >= 0.2:
                self.stream.write("\r\033[K" + self.line())
                self.stream.flush()
                self.last = now
        elif force or now - self.last >= 10:
            self.stream.write(self.line() + "\n")
            self.stream.flush()
            self.last = now

    def say(self, text):
        if self.tty and not self.quiet:
            self.stream.write("\r\033[K")
        self.stream.write(text + "\n")
        self.stream.flush()
        self.last = 0.0

    def finish(self):
        if self.tty and not self.quiet:
            self.stream.write("\r\033[K")
        self.stream.flush()


def dashboard(client):
    """The dashboard's address, and whether the scheduler serves its pages (they need bokeh,
    which Debian 12 does not package; the address then answers only /health and /metrics)."""
    try:
        link = client.dashboard_link
        has_bokeh = client.run_on_scheduler(lambda: __import__("importlib.util").util.find_spec("bokeh") is not None)
    except Exception:  # noqa: BLE001 - the address is a courtesy
        return "unknown"
    return link if has_bokeh else f"{link} (its pages need bokeh on the scheduler, which it lacks)"


def start_client(scheduler, workers, fork=False):
    """A client of the scheduler at `scheduler`, else of a new local cluster of `workers`
    single-threaded worker processes; returns (client, cluster or None).

    fork: the local workers are forks of this process rather than fresh interpreters (Dask's
    default, spawn, which imports Dask again in each: 1.5 to 3 s of a 2-core machine at every
    sweep, and as long again to stop them). `weft sweep` forks, its process being the driver
    alone; weft.sweep() spawns, since the caller's process may hold threads a fork would not
    carry over."""
    distributed = import_dask()
    import logging
    import dask
    if scheduler:
        try:
            return distributed.Client(scheduler, timeout="30s"), None
        except (OSError, ValueError) as e:
            raise SweepError(f"command line: --scheduler {scheduler}: no scheduler answered there ({e})")
    method = "fork" if fork else dask.config.get("distributed.worker.multiprocessing-method")
    # Forked workers ignore SIGINT: a Ctrl-C on the terminal reaches the whole process group, and
    # the driver stops them itself (each would otherwise print its KeyboardInterrupt's traceback).
    ignore = fork and threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if ignore else None
    try:
        with dask.config.set({"distributed.worker.multiprocessing-method": method, **QUIET_CLUSTER}):
            cluster = distributed.LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                               processes=True, dashboard_address=":0", silence_logs=logging.ERROR)
    finally:
        if ignore:
            signal.signal(signal.SIGINT, old)
    return distributed.Client(cluster), cluster


# A local cluster's housekeeping, slowed: each worker samples its threads' stacks every 10 ms
# (the profiler), every process checks its event loop every 20 ms, and workers and nannies read
# their memory every 100 ms. Idle, a cluster of two took 0.12 of a core that way (0.02 with
# these), which the runs lose on a machine whose cores they fill. A run is a subprocess whose
# worker thread only waits, so there is nothing to profile, and no task needs a memory check
# more often than a second.
QUIET_CLUSTER = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "500ms",
                 "distributed.worker.memory.monitor-interval": "1s", "distributed.admin.system-monitor.interval": "2s"}


def execute(sw, out, client=None, scheduler=None, workers=None, weft=None, quiet=False, stream=None, fork=False,
            rerun_other_builds=False):
    """Runs the sweep `sw` into `out`; returns (rows sorted by id, runs started). fork: a local
    cluster's workers are forks of this process (start_client). rerun_other_builds: the runs in
    `out` that another weft build made are run again (by default they are kept and counted)."""
    weft = find_weft(weft)
    (check_experiments if sw.experiment else check_scenes)(sw, weft)
    distributed = import_dask()  # before DIR is made
    try:
        build = {"key": worker._file_key(weft), "id": worker.build_identity(weft)}
    except OSError as e:
        raise SweepError(f"cannot read the weft command {weft}: {e.strerror}")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot create {out}: {e.strerror}")
    folders = RunFolders(out)
    stale = worker.remove_stale()
    stale_tables = remove_stale_tables(out, table_names(sw))
    done_rows, todo, others = [], [], 0
    for r in sw.runs:
        record = folders.finished(r)
        other = record is not None and record.get("weft_version") != build["id"]
        others += other
        if record is None or (other and rerun_other_builds):
            todo.append(r)
        else:
            done_rows.append(record["row"])
    progress = Progress(len(sw.runs), len(done_rows), quiet, stream)
    progress.failed = sum(1 for r in done_rows if r["status"] not in OK_STATUSES)
    removed = [f"{n} {what}" for n, what in ((folders.stale_removed, f"unfinished run folders in {folders.root}"),
                                             (stale_tables, f"unfinished tables in {out}"),
                                             (stale, f"temporary folders in {tempfile.gettempdir()}")) if n]
    if removed:
        progress.say(f"weft sweep: removed {' and '.join(removed)} that sweeps stopped or killed left")
    if others:
        how = ("run again, as asked" if rerun_other_builds else
               "kept (--rerun-other-builds, or rerun_other_builds=True in Python, runs them again)")
        progress.say(f"weft sweep: {others} of the runs in {out} were made by another weft build than this one "
                     f"({build['id']}; results.csv's weft_version says which): {how}")
    rows = list(done_rows)
    if not todo:
        progress.say(f"weft sweep: all {len(sw.runs)} runs are already in {out}")
        return write_tables(sw, out, rows), 0
    import cloudpickle
    cloudpickle.register_pickle_by_value(worker)
    own = client is None
    cluster = None
    if own:
        client, cluster = start_client(scheduler, workers, fork)
    try:
        n_workers = len(client.scheduler_info().get("workers", {}))
        where = f"the scheduler at {scheduler}" if scheduler else (
            "a local cluster" if own else f"the client's cluster ({client.scheduler.address})")
        link = dashboard(client)
        progress.say(f"weft sweep: {len(sw.runs)} runs, {len(todo)} to run ({len(done_rows)} already in {out}), "
                     f"on {where} of {n_workers} workers; dashboard: {link}")
        names = shipped_files(sw)
        files = {}
        for path, name in names.items():
            with open(path, "rb") as f:
                files[name] = f.read()
        # One object for the cluster, its key the hash of its contents (a dict given to scatter
        # would make its names the keys, shared with other sweeps on the same scheduler).
        files_future = client.scatter([files], hash=True)[0] if files else {}
        futures = {}
        for r in todo:
            argv, scene_text = task_command(sw, r, names)
            task = {"id": r.id, "hash": r.hash, "weft": weft, "threads": sw.threads, "timeout": sw.timeout,
                    "keep": "all" if sw.experiment else sw.keep, "argv": argv, "scene_text": scene_text,
                    "build": build}
            f = client.submit(worker.run_one, task, files_future, key=f"weft-run-{r.id}-{r.hash}", priority=-r.index,
                              pure=False)
            futures[f] = r
        keys = {f.key for f in futures}
        pending = set(futures)
        try:
            while pending:
                try:
                    done, pending = distributed.wait(pending, timeout=0.5, return_when="FIRST_COMPLETED")
                except distributed.TimeoutError:
                    done = set()
                for f in done:  # written, then let go: the cluster holds no run's outputs longer
                    rows.append(_finish(folders, futures.pop(f), f, sw, progress))
                    f.release()
                try:  # a worker's processing tasks include those queued on it: at most its threads run
                    threads = {w: i.get("nthreads", 1) for w, i in client.scheduler_info().get("workers", {}).items()}
                    progress.running = sum(min(sum(1 for k in ks if k in keys), threads.get(w, 1))
                                           for w, ks in client.processing().items())
                except Exception:  # noqa: BLE001 - progress only
                    pass
                progress.show(force=bool(done) and not progress.tty and progress.done == progress.total)
        except KeyboardInterrupt:
            for f in pending:
                f.cancel()
            progress.finish()
            # From the folders: a run whose folder was renamed into place just as Ctrl-C came
            # is in, though its row never reached `rows`.
            rows = [record["row"] for record in map(folders.finished, sw.runs) if record is not None]
            write_tables(sw, out, rows)
            progress.say(f"weft sweep: interrupted: {len(rows)} of {len(sw.runs)} runs are in {out}; the same "
                         "command runs the rest")
            raise
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
                # A run's folder whose worker the close (or a Ctrl-C) ended before it cleaned up.
                worker.remove_stale()
    progress.finish()
    failed = progress.failed
    progress.say(f"weft sweep: {len(sw.runs)} runs in {out}/results.csv ({len(todo)} run now, "
                 f"{failed} not ok)")
    return write_tables(sw, out, rows), len(todo)


def _finish(folders, run, future, sw, progress):
    try:
        result = future.result()
    except Exception as e:  # noqa: BLE001 - the task itself failed (e.g. its workers kept dying)
        result = {"exit_code": None, "error": f"the task failed on the cluster: {type(e).__name__}: {e}",
                  "outputs": {}, "seconds": 0.0, "host": None}
    result["timeout"] = sw.timeout
    result["experiment"] = sw.experiment
    summary = None
    report = "results.json" if sw.experiment else "summary.json"
    if report in result["outputs"]:
        try:
            summary = json.loads(result["outputs"][report])
        except ValueError:
            summary = None
    status, error = status_of(result, summary)
    row = row_of(run, result, summary, status, error)
    folders.write(run, result, row)
    progress.done += 1
    if status not in OK_STATUSES:
        progress.failed += 1
        progress.say(f"weft sweep: run {run.id} ({sw.culprit(run)}): {status}" + (f": {error}" if error else ""))
    return row
