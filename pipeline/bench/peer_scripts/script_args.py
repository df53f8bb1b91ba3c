"""The command line of the Python bench scripts beside this file (run as programs, each
in its own interpreter, which finds this module in the script's folder):

    SCRIPT X [Y ...] [--repeat R]

Numbers X, Y, ... (the first required) and a whole repeat count R >= 1 (default 1).
A bad line is one line on stderr; the caller exits with code 2."""
import sys


def arguments(argv, usage: str, most: int):
    """(repeat, [numbers]) of argv (argv[0] the script), at least one and at most `most`
    numbers; None after printing one line naming what is wrong."""
    name = argv[0].rsplit("/", 1)[-1]
    repeat, argv = 1, list(argv)
    if "--repeat" in argv:
        k = argv.index("--repeat")
        if k + 1 >= len(argv) or not argv[k + 1].isdigit() or int(argv[k + 1]) < 1:
            print(f"{name}: --repeat needs a whole number of runs >= 1", file=sys.stderr)
            return None
        repeat, argv = int(argv[k + 1]), argv[:k] + argv[k + 2:]
    if not 2 <= len(argv) <= most + 1:
        print(f"usage: python {name} {usage}", file=sys.stderr)
        return None
    try:
        return repeat, [float(a) for a in argv[1:]]
    except ValueError:
        what = usage.split(" [--")[0]
        print(f"{name}: {what} must be {'a number' if most == 1 else 'numbers'}, got "
              f"{' '.join(argv[1:])!r}", file=sys.stderr)
        return None
