"""Sweep files: reading, checking and expanding them into runs (docs/sweeps.md).

A sweep file is refused, before anything runs, with a SweepError whose message names the file,
the key and the value, as `weft run` names a scene's.
"""
import copy
import hashlib
import itertools
import json
import math
import os
import random
import re

TOP_KEYS = {"weft_sweep", "description", "scene", "experiment", "set", "vary", "combine", "keep", "threads",
            "timeout", "index"}
KEEP = ("last_frame", "frames", "glb", "pc2", "usda")
INDEX_COLUMNS = ("status", "exit_code", "vertices", "intersections", "steps", "wall_seconds", "fail_safe_work_J",
                 "fail_safe_moves", "clear")

# The experiments a sweep can run in place of `weft run` (docs/sweeps.md, "Experiment sweeps"):
# their figures (results.json's keys) are results.csv's columns; the options the sweep itself
# gives are not the sweep file's to set.
EXPERIMENTS = {
    "drape": {
        "figures": ("drape_coefficient", "nodes", "at_rest", "shadow_area_m2", "edge_radius_min_m",
                    "edge_radius_max_m", "final_max_speed_m_s", "simulated_time_s", "steps", "vertices",
                    "wall_seconds"),
        "reserved": ("out", "quiet", "no_pictures"),
        "keep": ("pictures",),
    },
}
_OPTION = re.compile(r"[a-z][a-z0-9_]*")


class SweepError(Exception):
    """A sweep file that cannot run: the message names the file, the key and the value."""


def show(value):
    return json.dumps(value)


_PATH_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[-?\d+\])*)")


def parse_key_path(path):
    """'colliders[0].speed' -> ['colliders', 0, 'speed']; None when it is not a key path."""
    if not isinstance(path, str) or not path:
        return None
    parts = []
    for piece in path.split("."):
        m = _PATH_PART.fullmatch(piece)
        if not m:
            return None
        parts.append(m.group(1))
        parts += [int(i) for i in re.findall(r"\[(-?\d+)\]", m.group(2))]
    return parts


def get_path(scene, parts):
    node = scene
    for p in parts:
        if isinstance(p, int):
            if not isinstance(node, list) or not -len(node) <= p < len(node):
                return None
        elif not isinstance(node, dict) or p not in node:
            return None
        node = node[p]
    return node


def set_path(scene, parts, value, where):
    """Sets scene[parts] = value, making missing objects on the way; a list index must exist."""
    node = scene
    for k, p in enumerate(parts):
        last = k + 1 == len(parts)
        if isinstance(p, int):
            if not isinstance(node, list):
                raise SweepError(f"{where}: the scene has no list there (index [{p}])")
            if not -len(node) <= p < len(node):
                raise SweepError(f"{where}: index [{p}] is beyond the scene's list of {len(node)}")
        elif not isinstance(node, dict):
            raise SweepError(f"{where}: the scene has no object there (key '{p}')")
        elif not last and p not in node:
            node[p] = [] if isinstance(parts[k + 1], int) else {}
        if last:
            node[p] = copy.deepcopy(value)
        else:
            node = node[p]


def absolutize(value, base):
    """Relative paths of files that exist in `base`, made absolute."""
    if isinstance(value, dict):
        return {k: absolutize(v, base) for k, v in value.items()}
    if isinstance(value, list):
        return [absolutize(v, base) for v in value]
    if isinstance(value, str) and value and not os.path.isabs(value) and os.path.isfile(os.path.join(base, value)):
        return os.path.abspath(os.path.join(base, value))
    return value


def added(base, delta, where):
    """base + delta for numbers and same-length lists of numbers (an axis's "add" form)."""
    number = (int, float)
    if isinstance(base, number) and isinstance(delta, number) and not isinstance(base, bool):
        return base + delta
    if isinstance(base, list) and isinstance(delta, list) and len(base) == len(delta):
        return [added(b, d, where) for b, d in zip(base, delta)]
    raise SweepError(f"{where}: cannot add {show(delta)} to the scene's value {show(base)} "
                     "(numbers, or lists of numbers of the same length)")


def random_offset(base, seed, size):
    """Offsets uniform in [-size, size], one per number of `base` (a number or nested lists of
    numbers), drawn from Python's Mersenne Twister seeded with `seed`: the same on every machine."""
    rng = random.Random(seed)

    def draw(b):
        return [draw(x) for x in b] if isinstance(b, list) else rng.uniform(-size, size)
    return draw(base)


class Run:
    """One run of a sweep: its id, the values of the axes and its scene (file paths absolute), or
    for an experiment sweep the experiment's options ({name: value}, as the sweep file names them)."""

    def __init__(self, index, run_id, params, scene, experiment=None):
        self.index, self.id, self.params, self.scene, self.experiment = index, run_id, params, scene, experiment
        text = json.dumps(scene if experiment is None else {"experiment": experiment, "options": scene}, sort_keys=True)
        self.hash = hashlib.sha256(text.encode()).hexdigest()[:16]


class Sweep:
    """A checked sweep file, expanded into its runs."""

    def __init__(self, spec, name, base_dir):
        self.name, self.base_dir = name, base_dir
        self._check(spec)
        self.runs = self._expand()

    def err(self, key, message):
        return SweepError(f"{self.name}: {key}: {message}")

    def _check(self, spec):
        if not isinstance(spec, dict):
            raise SweepError(f"{self.name}: a sweep file is a JSON object, got {show(spec)[:60]}")
        for key in spec:
            if key not in TOP_KEYS:
                raise self.err(key, f"unknown key (expected one of: {', '.join(sorted(TOP_KEYS))})")
        if spec.get("weft_sweep") != 1:
            raise self.err("weft_sweep", f"must be 1 (the sweep format's version), got {show(spec.get('weft_sweep'))}")
        self.experiment = spec.get("experiment")
        if self.experiment is not None:
            self._check_experiment(spec)
        else:
            self._check_scene(spec)
        self.vary = self._object(spec, "vary", axes=True)
        for key, value in self.vary.items():
            if isinstance(value, dict) and set(value) == {"named"}:
                self._check_named(f"vary.{key}.named", value["named"])
                continue
            if self.experiment and isinstance(value, dict):
                raise self.err(f"vary.{key}", "an experiment's axis is a list of values (or {\"named\": {...}}), "
                                              f"got {show(value)[:80]}")
            if isinstance(value, dict) and set(value) == {"random"}:
                self._check_random(f"vary.{key}.random", value["random"])
                continue
            values = value.get("add") if isinstance(value, dict) and set(value) == {"add"} else value
            if not isinstance(values, list):
                raise self.err(f"vary.{key}", "must be a list of values (or {\"add\": [...]}, {\"random\": {...}} or "
                                              f"{{\"named\": {{...}}}}), got {show(value)[:80]}")
            if not values:
                raise self.err(f"vary.{key}", "an empty list: an axis needs one value at least")
            if self.experiment:
                for v in values:
                    self._check_option_value(f"vary.{key}", v)
        self.combine = spec.get("combine", "product")
        if self.combine not in ("product", "zip"):
            raise self.err("combine", f"must be \"product\" or \"zip\", got {show(self.combine)}")
        if self.combine == "zip" and self.vary:
            lengths = {k: len(self._values(v)) for k, v in self.vary.items()}
            if len(set(lengths.values())) > 1:
                raise self.err("vary", "zipped axes must have as many values each, got " +
                               ", ".join(f"{k}: {n}" for k, n in lengths.items()))
        kinds = EXPERIMENTS[self.experiment]["keep"] if self.experiment else KEEP
        self.keep = spec.get("keep", [])
        if not isinstance(self.keep, list) or any(k not in kinds for k in self.keep):
            raise self.err("keep", f"must be a list of {', '.join(kinds)}, got {show(self.keep)}")
        self.threads = spec.get("threads", 1)
        if not isinstance(self.threads, int) or isinstance(self.threads, bool) or not 1 <= self.threads <= 4096:
            raise self.err("threads", f"must be an integer from 1 to 4096 (threads of each run), got {show(self.threads)}")
        self.timeout = spec.get("timeout")
        if self.timeout is not None and (not isinstance(self.timeout, (int, float)) or isinstance(self.timeout, bool)
                                         or not 0 < self.timeout < math.inf):
            raise self.err("timeout", f"must be a number of seconds > 0, got {show(self.timeout)}")
        self.index = spec.get("index")
        if self.index is not None:
            self._check_index(self.index)
        self.description = spec.get("description", "")

    def _check_experiment(self, spec):
        if self.experiment not in EXPERIMENTS:
            raise self.err("experiment", f"must be one of {', '.join(sorted(EXPERIMENTS))} (the experiments a sweep "
                                         f"runs), got {show(self.experiment)}")
        if "scene" in spec:
            raise self.err("scene", f"an experiment sweep has no scene (weft experiment {self.experiment} makes its "
                                    "own); its \"set\" and \"vary\" name the experiment's options")
        self.scene_file, self.scene_dir = f"weft experiment {self.experiment}", self.base_dir
        self.base = {}
        self.set = self._object(spec, "set")
        for key, value in self.set.items():
            self._check_option_value(f"set.{key}", value)

    def _check_option_value(self, key, value):
        if not isinstance(value, (str, int, float, bool)) or (isinstance(value, float) and not math.isfinite(value)):
            raise self.err(key, f"an experiment's option takes a number, a string or true/false, got {show(value)[:80]}")

    def _check_named(self, key, named):
        if not isinstance(named, dict) or not named:
            raise self.err(key, "must be a non-empty object: NAME -> {KEY PATH: value, ...} (the settings of that "
                                f"name), got {show(named)[:80]}")
        for name, settings in named.items():
            if not isinstance(settings, dict):
                raise self.err(f"{key}.{name}", f"must be an object of {self._setting_kind()} ({{}}: the base as it "
                                                f"is), got {show(settings)[:80]}")
            for path, value in settings.items():
                self._check_setting(f"{key}.{name}.{path}", path)
                if self.experiment:
                    self._check_option_value(f"{key}.{name}.{path}", value)

    def _setting_kind(self):
        return "option names" if self.experiment else "key paths"

    def _check_setting(self, key, path):
        if self.experiment:
            if not isinstance(path, str) or not _OPTION.fullmatch(path):
                raise self.err(key, f"not an option of weft experiment {self.experiment} (names such as "
                                    "specimen_diameter for --specimen-diameter)")
            if path in EXPERIMENTS[self.experiment]["reserved"]:
                raise self.err(key, f"--{path.replace('_', '-')} is the sweep's own to give")
        elif parse_key_path(path) is None:
            raise self.err(key, "not a key path (names joined by dots, list indices in brackets: "
                                "colliders[0].friction)")

    def _check_scene(self, spec):
        scene = spec.get("scene")
        if isinstance(scene, dict):
            self.scene_file, self.scene_dir = "scene (object)", self.base_dir
            base = scene
        else:
            if not isinstance(scene, str) or not scene:
                raise self.err("scene", f"must be a scene file's path (or a scene object), got {show(scene)}")
            path = scene if os.path.isabs(scene) else os.path.join(self.base_dir, scene)
            try:
                with open(path) as f:
                    base = json.load(f)
            except OSError as e:
                raise self.err("scene", f"cannot read {show(scene)} ({path}): {e.strerror}")
            except ValueError as e:
                raise self.err("scene", f"{show(scene)} is not JSON: {e}")
            self.scene_file, self.scene_dir = path, os.path.dirname(os.path.abspath(path))
        if not isinstance(base, dict):
            raise self.err("scene", "the scene is not a JSON object")
        self.base = absolutize(base, self.scene_dir)
        self.set = self._object(spec, "set")

    def _check_index(self, index):
        if not isinstance(index, dict) or set(index) - {"file", "columns"} or not isinstance(index.get("file"), str) \
                or "/" in index["file"] or not index["file"].endswith(".csv"):
            raise self.err("index", "must be {\"file\": \"NAME.csv\", \"columns\": {NAME: KEY PATH or one of " +
                           ", ".join(INDEX_COLUMNS) + "}}, got " + show(index)[:80])
        columns = index.get("columns", {})
        if not isinstance(columns, dict):
            raise self.err("index.columns", f"must be an object, got {show(columns)[:80]}")
        known = (("status", "exit_code") + EXPERIMENTS[self.experiment]["figures"]) if self.experiment else INDEX_COLUMNS
        for name, what in columns.items():
            if what not in known and what not in self.vary:
                raise self.err(f"index.columns.{name}", f"must name an axis of \"vary\" or one of {', '.join(known)}"
                               f", got {show(what)}")

    def _check_random(self, key, r):
        if not isinstance(r, dict) or set(r) != {"seeds", "size"}:
            raise self.err(key, f"must be {{\"seeds\": N or [seed, ...], \"size\": S}}, got {show(r)[:80]}")
        seeds, size = r["seeds"], r["size"]
        count = isinstance(seeds, int) and not isinstance(seeds, bool) and seeds >= 1
        listed = isinstance(seeds, list) and seeds and all(isinstance(x, int) and not isinstance(x, bool) for x in seeds)
        if not (count or listed):
            raise self.err(f"{key}.seeds", f"must be a count >= 1 or a non-empty list of integers, got {show(seeds)[:80]}")
        if not isinstance(size, (int, float)) or isinstance(size, bool) or not 0 < size < math.inf:
            raise self.err(f"{key}.size", f"must be a number > 0, got {show(size)}")

    def _object(self, spec, key, axes=False):
        value = spec.get(key, {})
        if not isinstance(value, dict):
            raise self.err(key, f"must be an object of {self._setting_kind()}, got {show(value)[:80]}")
        for path, axis in value.items():
            if axes and isinstance(axis, dict) and set(axis) == {"named"}:
                if not isinstance(path, str) or not _OPTION.fullmatch(path.lower()):
                    raise self.err(f"{key}.{path}", "a named axis's name is its column's: letters, digits and _")
                continue
            self._check_setting(f"{key}.{path}", path)
        return value

    @staticmethod
    def _values(axis):
        """An axis's values: its list, its offsets ("add"), its seeds ("random") or its names ("named")."""
        if isinstance(axis, dict) and "named" in axis:
            return list(axis["named"])
        if isinstance(axis, dict) and "random" in axis:
            seeds = axis["random"]["seeds"]
            return list(range(seeds)) if isinstance(seeds, int) else seeds
        return axis["add"] if isinstance(axis, dict) else axis

    def _expand(self):
        base = copy.deepcopy(self.base)
        for key, value in self.set.items():
            set_path(base, parse_key_path(key), absolutize(value, self.base_dir), f"{self.name}: set.{key}")
        keys = list(self.vary)
        columns = [self._values(self.vary[k]) for k in keys]
        combos = list(zip(*columns)) if self.combine == "zip" else list(itertools.product(*columns))
        if not keys:
            combos = [()]
        width = max(4, len(str(len(combos) - 1)))
        runs = []
        for index, combo in enumerate(combos):
            scene = copy.deepcopy(base)
            params = {}
            for key, value in zip(keys, combo):
                where = f"{self.name}: vary.{key}: value {show(value)}"
                params[key] = value
                axis = self.vary[key]
                if isinstance(axis, dict) and "named" in axis:
                    for path, setting in axis["named"][value].items():
                        set_path(scene, parse_key_path(path), absolutize(setting, self.base_dir),
                                 f"{self.name}: vary.{key}.named.{value}.{path}")
                    continue
                parts = parse_key_path(key)
                if isinstance(axis, dict):
                    old = get_path(base, parts)
                    if old is None:
                        raise SweepError(f"{where}: \"{next(iter(axis))}\" needs the scene to have a value there")
                    if "random" in axis:
                        value = random_offset(old, value, axis["random"]["size"])
                    value = added(old, value, where)
                    params[key] = params[key] if "random" in axis else value
                set_path(scene, parts, absolutize(value, self.base_dir), where)
            runs.append(Run(index, f"{index:0{width}d}", params, scene, self.experiment))
        return runs

    def culprit(self, run):
        """The sweep keys a refused scene of `run` comes from, for the message."""
        if not run.params:
            return "set" if self.set or self.experiment else "scene"
        return ", ".join(f"vary.{k} = {show(v)}" for k, v in run.params.items())


def load(spec, base_dir=None, name=None):
    """A Sweep from a sweep file's path or from a dict (its relative paths relative to base_dir,
    by default the current folder)."""
    if isinstance(spec, dict):
        return Sweep(spec, name or "sweep (dict)", os.path.abspath(base_dir or "."))
    path = os.fspath(spec)
    try:
        with open(path) as f:
            text = f.read()
    except OSError as e:
        raise SweepError(f"{path}: cannot read: {e.strerror}")
    try:
        data = json.loads(text, object_pairs_hook=_no_repeats(path))
    except ValueError as e:
        raise SweepError(f"{path}: not JSON: {e}")
    return Sweep(data, name or path, os.path.dirname(os.path.abspath(path)))


def _no_repeats(path):
    def hook(pairs):
        seen = {}
        for key, value in pairs:
            if key in seen:
                raise SweepError(f"{path}: {key}: repeated within one object")
            seen[key] = value
        return seen
    return hook
