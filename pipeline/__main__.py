"""Command line: `shroud COMMAND ...` or `python -m pipeline COMMAND ...` (see `--help`)."""
from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from .errors import UsageError, interrupt_in_chain
from .study.execution.run_parser import add_run_parser, configure_logging

# The commands import what computes when they run (each in its function): the parser,
# `--help` and a bad argument load argparse and the small modules above only, not
# scikit-fem, meshio, the compiled kernels, SciPy, xarray or matplotlib.


def _prog() -> str:
    """The command as it was invoked: `shroud` (console script) or `python -m pipeline`."""
    name = os.path.basename(sys.argv[0] if sys.argv and sys.argv[0] else "")
    if name in ("", "__main__.py", "-c", "-m") or name.startswith("python"):
        return "python -m pipeline"
    return name


def build_parser() -> argparse.ArgumentParser:
    """The command line: `run`, `check`, `hysteresis`, `optimise`, `bench` and `keys`."""
    p = argparse.ArgumentParser(
        prog=_prog(),
        description="Shrouded bladed disks with dry friction: Yang-Menq contact, "
        "harmonic balance, continuation, studies.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    add_run_parser(sub).set_defaults(func=_cmd_run)

    c = sub.add_parser("check", help="validate a study without computing (cases, solver, "
                                     "estimated cost), or a dataset against its contract")
    c.add_argument("file", metavar="STUDY.toml|FILE.nc", help="study file or dataset")
    c.add_argument("--quick", action="store_true",
                   help="check the study's [quick] variant (the one `run --quick` runs)")
    c.add_argument("--workers", type=int, default=None, metavar="N",
                   help="workers the cost estimate assumes (default: one per CPU core)")
    c.set_defaults(func=_cmd_check)

    h = sub.add_parser("hysteresis", help="draw the Yang-Menq time history and hysteresis loop (PNG)")
    h.add_argument("--out", default="results/hysteresis.png",
                   help="PNG file to write (a folder: hysteresis.png in it)")
    h.add_argument("--mu", type=float, default=0.4, help="friction coefficient [-] (default: "
                   "%(default)s)")
    h.add_argument("--ku", type=float, default=1.0, help="tangential stiffness [N/m] (default: "
                   "%(default)s)")
    h.add_argument("--kv", type=float, default=1.0, help="normal stiffness [N/m] (default: "
                   "%(default)s)")
    h.add_argument("--n0", type=float, default=1.0, help="preload [N], negative: a gap "
                   "(default: %(default)s)")
    h.add_argument("--u", type=float, default=3.0, metavar="U", help="the relative motion "
                   "u = U cos(tau) [m] (default: %(default)s)")
    h.add_argument("--v", type=float, nargs=2, default=(0.5, 2.0), metavar=("VC", "VS"),
                   help="the normal motion v = VC cos(tau) + VS sin(tau) [m] (default: 0.5 2.0: "
                   "with the other defaults it separates, slips both ways and sticks)")
    h.set_defaults(func=_cmd_hysteresis)

    o = sub.add_parser("optimise", help="the preload that minimises the resonant peak of a study")
    o.add_argument("study", metavar="STUDY.toml", help="study file with [output.optimum_preload]")
    o.add_argument("--quick", action="store_true", help="use the study's [quick] solver settings")
    o.add_argument("--out", default="results", help="directory for <name>/optimum_preload.png")
    o.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes for the search's grid (default: one per "
                        "CPU core; 1 = run in this process)")
    o.set_defaults(func=_cmd_optimise)

    b = sub.add_parser("bench", help="benchmarks that print tables")
    b.add_argument("what", choices=["contact", "hbm", "evaluations", "blade", "disk", "parallel",
                                    "peers", "stability", "estimate", "modes", "montecarlo",
                                    "interface"],
                   help="what to benchmark")
    b.add_argument("studies", nargs="*", metavar="STUDY",
                   help="estimate, parallel: studies to run (names in studies/ or files; "
                        "default all / the paper's)")
    b.add_argument("--quick", action="store_true", help="fewer repetitions")
    b.add_argument("--nlvib", metavar="PATH", default=None,
                   help="peers: the NLvib folder (default $NLVIB_PATH); needs octave on PATH")
    b.add_argument("--pyharm-python", metavar="PATH", default=None,
                   help="peers: a Python interpreter with pyHarm (default $PYHARM_PYTHON)")
    b.set_defaults(func=_cmd_bench)

    k = sub.add_parser("keys", help="every study-file key with its unit and default "
                                    "(markdown; the table in studies/README.md)")
    k.set_defaults(func=_cmd_keys)
    return p


def _cmd_run(args) -> int:
    from .study.execution.run import cmd_run   # deferred: the parser loads nothing heavy

    return cmd_run(args)


def _cmd_keys(args) -> int:
    from .study.files.keys import markdown   # deferred: the key table, for this command only

    print(markdown(), end="")
    return 0


def _cmd_hysteresis(args) -> int:
    import numpy as np   # deferred: the parser loads nothing heavy

    # looked up at each call: a replaced `plots.hysteresis_figure` is the one drawn
    from .study.figures.plots import check_element, hysteresis_figure

    out = Path(args.out)
    if out.is_dir():
        out = out / "hysteresis.png"
    if out.suffix.lower() != ".png":
        why = ("no such folder (give an existing folder, or a file name ending in .png)"
               if not out.exists() else "must be a .png file or a folder")
        print(f"error: --out: {args.out}: {why}", file=sys.stderr)
        return 2

    for name, value in (("u", args.u), ("v", args.v[0]), ("v", args.v[1])):
        if not np.isfinite(value):
            print(f"error: hysteresis: --{name}: must be finite, got {value}", file=sys.stderr)
            return 2
    U, V = np.zeros((1, 7)), np.zeros((1, 7))
    U[0, 1], (V[0, 1], V[0, 2]) = args.u, args.v
    try:
        check_element(args.mu, args.ku, args.kv, args.n0)
    except ValueError as exc:   # the contact element's own check names its parameter
        print(f"error: hysteresis: --{str(exc).split()[0]}: {exc}", file=sys.stderr)
        return 2
    path = hysteresis_figure(out, mu=args.mu, ku=args.ku, kv=args.kv, n0=args.n0, U=U, V=V)
    print(f"wrote {path}")
    return 0


def _cmd_optimise(args) -> int:
    """Optimum preload by a search on the exact peak (peak_tracking.optimum_preload)."""
    from .study.figures.optimum_figure import optimum_figure   # deferred: only `optimise` draws it
    # deferred: the parser loads nothing heavy
    from .study.execution.cases import StaticDivergence, default_solver
    from .study.execution.checkpoint import checkpoint_dir
    from .study.execution.optimum_search import (find_optimum, optimum_words, search_warnings,
                                                 variable_of)
    from .study.execution.run import check_writable, sigint_interrupts
    from .study.execution.search_checkpoint import search_file
    from .study.files.declared import UndeclaredSeparation
    from .study.files.documents import load_study
    from .study.kinds import kind_of

    study = load_study(args.study, quick=args.quick)
    workers = args.workers
    if workers is None:
        workers = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                   else (os.cpu_count() or 1))
    if workers < 1:
        raise UsageError(f"{args.study}: --workers: must be >= 1, got {workers}")
    if not kind_of(study).optimum:   # a modes, nonlinear-modes or accuracy-cost study
        raise UsageError(f"{args.study}: study.kind: an optimum-preload search needs a "
                         f"\"response\" study, this one is {kind_of(study).word!r}")
    if study.output.optimum is None:
        raise UsageError(f"{args.study}: output.optimum_preload: missing: give dof and "
                         "bounds = [low, high] (N) for the search (or "
                         "[output.optimum_interference], bounds in m)")
    check_writable(args.study, Path(args.out), study.name, dataset=False)   # its figure
    # the evaluations are kept as they come (with `run`'s cases of the same study):
    # a rerun after Ctrl-C resumes the search
    cdir = checkpoint_dir(study, args.out, default_solver(study))
    try:
        with sigint_interrupts():
            res = find_optimum(study, None, cdir, workers=workers)
    except UndeclaredSeparation as exc:
        print(f"error: {args.study}: scene.effects: {exc}", file=sys.stderr)
        return 1
    except StaticDivergence as exc:
        print(f"error: {args.study}: scene: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        kept = search_file(cdir)
        print("interrupted" + (f": the search's evaluations are kept in {kept}, rerun the "
                               "same command to resume" if kept.is_file() else ""),
              file=sys.stderr)
        return 130
    search_file(cdir).unlink(missing_ok=True)
    if cdir.is_dir() and not any(cdir.iterdir()):
        cdir.rmdir()
    o = study.output.optimum
    fr = study.sweep.frequency
    var, unit = variable_of(study)
    print(f"{study.name}: {var} minimising the peak of {o['dof']}: {optimum_words(res, unit)} "
          f"(peak {res['peak']:.6g} m at {res['peak_omega'] / fr.to_rad_s:.6g} {fr.unit}; "
          f"{len(res['evaluations'])} evaluations: grid of {len(res['grid'])}, "
          f"{len(res['brackets'])} minimum(s) bracketed, {len(res.get('skipped', ()))} of them "
          f"not refined (their parabola above the best), {res['reused']} reused; "
          f"{res['wall_time']:.1f} s)")
    static = res.get("static", {})
    print(f"{var + ' [' + unit + ']':>18} {'peak [m]':>14} {'at [' + fr.unit + ']':>12}"
          + (f" {'static load [N]':>16} {'pairs closed':>12}" if static else ""))
    for n0, a, om in res["evaluations"]:
        more = ""
        if float(n0) in static:
            load, pairs = static[float(n0)]
            more = f" {float(sum(load)):16.6g} {int(sum(pairs)):12d}"
        print(f"{n0:18.6g} {a:14.6g} {om / fr.to_rad_s:12.6g}{more}"
              f"{'  <- optimum' if n0 == res['preload'] else ''}")
    path = optimum_figure(Path(args.out) / study.name / f"optimum_{var}.png", res, o["dof"],
                          study.title, (var, unit))
    print(f"wrote {path}")
    for what in search_warnings(study, res):
        print(f"warning: {args.study}: output.optimum_{var}: {what}", file=sys.stderr)
    return 0



def _cmd_bench(args) -> int:
    from . import bench   # deferred: the benchmarks load only for `bench`

    options = ({"nlvib": args.nlvib, "pyharm_python": args.pyharm_python}
               if args.what == "peers" else {})
    if args.studies and args.what not in ("estimate", "parallel"):
        print(f"error: bench {args.what}: takes no STUDY arguments", file=sys.stderr)
        return 2
    if args.what == "estimate":
        options = {"studies": tuple(args.studies)}
    if args.what == "parallel" and args.studies:   # long studies: the pool against Dask
        options = {"studies": tuple(args.studies), "serial": False}
    return bench.run(args.what, quick=args.quick, **options)


def _cmd_check(args) -> int:
    from .study.files.check import check   # deferred: `--help` and `run` never load it

    if not args.verbose:   # a check prints its verdict only: no model-building chatter
        logging.getLogger("pipeline.structure").setLevel(logging.WARNING)
    return check(args.file, quick=args.quick, workers=args.workers)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    configure_logging(args.verbose)
    try:
        return args.func(args)
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except SystemError as exc:  # an interrupt a compiled kernel's dispatcher wrapped
        if not interrupt_in_chain(exc):
            raise
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
