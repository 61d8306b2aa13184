# Shared set-up of the Python module's tests: the `weft` command beside the module (WEFT_EXE,
# set by ctest) and small scenes as dicts.
import copy
import os
import subprocess

import pytest

WEFT_EXE = os.environ.get("WEFT_EXE", "")


def sheet_scene():
    """A 0.3 m square of 7 x 7 vertices held at two corners, 0.1 s at dt = 10 ms."""
    return {
        "weft_scene": 1,
        "duration": 0.1,
        "frame_interval": 0.02,
        "integrator": {"method": "implicit-midpoint", "dt": 0.01},
        "cloth": {
            "mesh": {"grid": {"size": [0.3, 0.3], "vertices": [7, 7]}},
            "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.15, 1.0, 0.0]},
            "material": {"surface_density": 0.15, "weft": 100, "warp": 100, "shear": 10,
                         "bending_rigidity": 1e-4, "viscosity": 0.0},
            "pins": {"grid": [[0, 0], [-1, 0]]},
        },
    }


def sphere_scene():
    """A free 0.4 m square of 9 x 9 vertices falling onto a sphere: contacts and self-collision."""
    return {
        "weft_scene": 1,
        "duration": 0.1,
        "frame_interval": 0.02,
        "integrator": {"method": "bdf2", "dt": 0.005},
        "cloth": {
            "mesh": {"grid": {"size": [0.4, 0.4], "vertices": [9, 9]}},
            "placement": {"rotation_deg": [-90, 0, 0], "translation": [-0.2, 0.31, 0.2]},
            "material": "cotton",
        },
        "colliders": [{"type": "sphere", "centre": [0, 0, 0], "radius": 0.3, "thickness": 0.003}],
    }


@pytest.fixture
def sheet():
    return copy.deepcopy(sheet_scene())


@pytest.fixture
def sphere():
    return copy.deepcopy(sphere_scene())


def run_weft(*args):
    """Runs the `weft` command; returns (exit status, stderr)."""
    if not WEFT_EXE:
        pytest.skip("WEFT_EXE is not set (ctest sets it)")
    r = subprocess.run([WEFT_EXE, *map(str, args)], capture_output=True, text=True, timeout=300)
    return r.returncode, r.stderr
