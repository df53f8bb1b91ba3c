"""The `run` command's arguments and the command line's logging: argparse and logging
only, so that `python -m pipeline --help` (and `run --help`) load none of the modules
that compute (`run` imports them when it runs)."""
from __future__ import annotations

import logging


def configure_run_parser(r):
    """The arguments of `run` on the parser `r` (its command is set by the caller)."""
    r.add_argument("study", metavar="STUDY.toml", help="study file (see studies/README.md)")
    r.add_argument("--out", default="results", metavar="DIR",
                   help="output directory: DIR/<name>.nc and DIR/<name>/*.png (default: results)")
    r.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: one per CPU core; 1 = run in this process)")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address, e.g. tcp://host:8786 (overrides --workers)")
    r.add_argument("--quick", action="store_true",
                   help="use the study's [quick] overrides (fewer cases, fewer harmonics)")
    r.add_argument("--no-figures", dest="figures", action="store_false", help="skip the figures")


def add_run_parser(subparsers):
    """Register `run` on the CLI's subparsers (`pipeline/__main__.py`); the caller sets
    its command (`set_defaults(func=...)`)."""
    r = subparsers.add_parser("run", help="run a study file: dataset (netCDF) and figures")
    configure_run_parser(r)
    return r


def configure_logging(verbose: bool):
    """Root logging for the command line; scikit-fem's per-step INFO lines and the
    continuation's per-branch summary only with --verbose."""
    logging.basicConfig(level=logging.DEBUG if verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    quiet = logging.NOTSET if verbose else logging.WARNING
    for name in ("skfem", "pipeline.solve.continuation.pseudo_arclength"):
        logging.getLogger(name).setLevel(quiet)
