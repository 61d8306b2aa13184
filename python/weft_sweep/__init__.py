"""weft's sweeps: many runs of one scene on Dask's distributed scheduler (docs/sweeps.md).

`weft sweep SWEEP.json --out DIR` runs this package's driver (python3 -m weft_sweep); from Python,
`weft.sweep(spec, out=..., client=None)` (or weft_sweep.sweep) returns the results as a pandas
DataFrame.
"""
import os

from .driver import DaskMissing, OutputError, execute
from .spec import SweepError, load

__all__ = ["sweep", "load", "SweepError", "OutputError", "DaskMissing"]


def sweep(spec, out, client=None, *, scheduler=None, workers=None, weft=None, base_dir=None, quiet=True,
          rerun_other_builds=False):
    """Runs a sweep and returns its results (DIR/results.csv's rows) as a pandas DataFrame.

    spec: a sweep file's path, or a dict in its layout (relative paths relative to base_dir, by
    default the current folder). out: the output folder; runs already finished there are
    skipped, those another weft build made too unless rerun_other_builds (results.csv's
    weft_version names each run's build). client: a dask.distributed.Client to run on; without
    one, a local cluster of `workers` single-threaded workers (default: the cores) is started
    for the sweep and closed after it, or the scheduler at `scheduler` is used. weft: the `weft` command (default:
    $WEFT_EXE, else the one this module was built with, else `weft` on the PATH). The DataFrame
    has one row per run, failed ones included, and a `runs_started` attribute in `df.attrs`.
    """
    import pandas as pd

    sw = load(spec, base_dir=base_dir)
    rows, started = execute(sw, os.fspath(out), client=client, scheduler=scheduler, workers=workers, weft=weft,
                            quiet=quiet, rerun_other_builds=rerun_other_builds)
    frame = pd.DataFrame(rows)
    frame.attrs["runs_started"] = started
    return frame
