"""``python -m smokelab_xr RUN_DIR …``: print what a run folder holds, as
the Datasets ``open_run`` gives (a check that a folder opens, without a
notebook). A path that is not a run exits 2 with one line naming it."""

import argparse
import sys

from .run import NotARunError, open_run


def main(argv=None) -> int:
    """Print each folder's volumes, metrics, tables and sub-runs."""
    parser = argparse.ArgumentParser(
        prog="python -m smokelab_xr",
        description="Print a smokelab run folder's volumes, metrics and tables as xarray Datasets.",
    )
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="a run folder or results/<id>/")
    args = parser.parse_args(argv)
    try:
        for path in args.runs:
            run = open_run(path)
            print(run)
            print("volumes:", run.volumes, sep="\n")
            print("metrics:", run.metrics, sep="\n")
            for name, table in run.tables.items():
                print(f"table {name}:", table, sep="\n")
            if run.runs:
                print("runs:", ", ".join(run.runs))
    except NotARunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
