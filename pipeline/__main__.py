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

    b = sub.add_parser("bench", help="benchmarks that print tables")
    b.add_argument("what", choices=["contact", "hbm", "blade"], help="what to benchmark")
    b.add_argument("--quick", action="store_true", help="fewer repetitions")
    b.set_defaults(func=_cmd_bench)
    return p


def _cmd_hysteresis(args) -> int:
    from .plots import hysteresis_figure

    path = hysteresis_figure(args.out, mu=args.mu, ku=args.ku, kv=args.kv, n0=args.n0)
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
