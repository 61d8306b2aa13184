"""`python3 -m weft_sweep SWEEP.json --out DIR --weft WEFT`: the driver `weft sweep` runs."""
import argparse
import sys

from .driver import EXIT_INTERRUPTED, EXIT_OUTPUT_FAILED, EXIT_SOME_FAILED, OK_STATUSES, DaskMissing, OutputError, execute
from .spec import SweepError, load


def main(argv=None):
    p = argparse.ArgumentParser(prog="weft sweep", description="Runs a sweep file's runs on Dask (docs/sweeps.md)")
    p.add_argument("sweep")
    p.add_argument("--out", required=True)
    p.add_argument("--weft", help="the weft command the runs use (default: $WEFT_EXE, else weft on the PATH)")
    p.add_argument("--scheduler")
    p.add_argument("--workers", type=int)
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--rerun-other-builds", action="store_true")
    a = p.parse_args(argv)
    try:
        sw = load(a.sweep)
        rows, _ = execute(sw, a.out, scheduler=a.scheduler, workers=a.workers, weft=a.weft, quiet=a.quiet, fork=True,
                          rerun_other_builds=a.rerun_other_builds)
    except SweepError as e:
        print(f"weft: error: {e}", file=sys.stderr)
        return 2
    except DaskMissing as e:
        print(f"weft: error: {e}", file=sys.stderr)
        return 1
    except OutputError as e:
        print(f"weft: error: {e}", file=sys.stderr)
        return EXIT_OUTPUT_FAILED
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    return 0 if all(r["status"] in OK_STATUSES for r in rows) else EXIT_SOME_FAILED


if __name__ == "__main__":
    sys.exit(main())
