"""Command line: `python -m pipeline COMMAND ...` (see `--help`)."""
from __future__ import annotations

import argparse
import logging
import sys


from .errors import UsageError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m pipeline",
        description="Shrouded bladed disks with dry friction: Yang-Menq contact, "
        "harmonic balance, continuation, studies.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    from .study import add_run_parser
    add_run_parser(sub)

    h = sub.add_parser("hysteresis", help="draw the Yang-Menq time history and hysteresis loop (PNG)")
    h.add_argument("--out", default="results/hysteresis.png", help="PNG file to write")
    h.add_argument("--mu", type=float, default=0.4, help="friction coefficient [-]")
    h.add_argument("--ku", type=float, default=1.0, help="tangential stiffness [N/m]")
    h.add_argument("--kv", type=float, default=1.0, help="normal stiffness [N/m]")
    h.add_argument("--n0", type=float, default=1.0, help="preload [N] (negative = gap)")
    h.set_defaults(func=_cmd_hysteresis)

    o = sub.add_parser("optimise", help="the preload that minimises the resonant peak of a study")
    o.add_argument("study", metavar="STUDY.toml", help="study file with [output.optimum_preload]")
    o.add_argument("--quick", action="store_true", help="use the study's [quick] solver settings")
    o.add_argument("--out", default="results", help="directory for <name>/optimum_preload.png")
    o.set_defaults(func=_cmd_optimise)

    b = sub.add_parser("bench", help="benchmarks that print tables")
    b.add_argument("what", choices=["contact", "hbm", "blade", "parallel"], help="what to benchmark")
    b.add_argument("--quick", action="store_true", help="fewer repetitions")
    b.set_defaults(func=_cmd_bench)
    return p


def _cmd_hysteresis(args) -> int:
    from .plots import hysteresis_figure

    path = hysteresis_figure(args.out, mu=args.mu, ku=args.ku, kv=args.kv, n0=args.n0)
    print(f"wrote {path}")
    return 0


def _cmd_optimise(args) -> int:
    """Optimum preload by a search on the exact peak (response.optimum_preload)."""
    from pathlib import Path

    from .plots import optimum_figure
    from .scene import load_study
    from .study import find_optimum

    study = load_study(args.study, quick=args.quick)
    if study.output.optimum is None:
        raise UsageError(f"{args.study}: output.optimum_preload: missing: give dof and "
                         "bounds = [low, high] (N) for the search")
    res = find_optimum(study)
    o = study.output.optimum
    print(f"{study.name}: preload minimising the peak of {o['dof']}: {res['preload']:.6g} N "
          f"(peak {res['peak']:.6g} m at {res['peak_omega']:.6g} rad/s; "
          f"{len(res['evaluations'])} evaluations, {res['wall_time']:.1f} s)")
    print(f"{'preload [N]':>14} {'peak [m]':>14} {'at [rad/s]':>12}")
    for n0, a, om in res["evaluations"]:
        print(f"{n0:14.6g} {a:14.6g} {om:12.6g}{'  <- optimum' if n0 == res['preload'] else ''}")
    path = optimum_figure(Path(args.out) / study.name / "optimum_preload.png", res, o["dof"],
                          study.title)
    print(f"wrote {path}")
    return 0


def _cmd_bench(args) -> int:
    from . import bench

    return bench.run(args.what, quick=args.quick)


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.func(args)
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
