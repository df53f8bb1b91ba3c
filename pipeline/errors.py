"""The one exception the command line turns into `error: <file>: <field>: <what>`, and
how it recognises an interrupt (exit 130) however it arrives."""
from __future__ import annotations


class UsageError(Exception):
    """Bad user input: reported as one line `error: <file>: <field>: <what>`, exit 2."""


def interrupt_in_chain(exc) -> bool:
    """Whether exc is, or was raised while handling or because of, a KeyboardInterrupt.

    An interrupt that lands while a compiled (Numba) function's dispatcher runs
    Python code (e.g. unpickling its cached constants) reaches the caller as
    SystemError("... returned a result with an exception set"), caused by the
    KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
