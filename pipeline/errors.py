"""The one exception the command line turns into `error: <file>: <field>: <what>`, how
it recognises an interrupt (exit 130) however it arrives, and how an atomic write holds
one back until it is done."""
from __future__ import annotations

import signal
import threading


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


class interrupt_deferred:
    """Context manager: a SIGINT that arrives inside the block is handed to the previous
    handler (KeyboardInterrupt) only when the block ends.  For the atomic writes of
    checkpoints: an interrupt inside the netCDF library's write can leave its lock
    held, and the cleanup then waits on that lock for ever.  No-op outside the main
    thread (signal handlers can only be set there)."""

    def __enter__(self):
        self._old, self._held = None, False
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._hold)
        return self

    def _hold(self, signum, frame):
        self._held = True

    def __exit__(self, exc_type, exc, tb):
        if self._old is None:
            return False
        signal.signal(signal.SIGINT, self._old)
        if self._held and callable(self._old):
            self._old(signal.SIGINT, None)     # default_int_handler: KeyboardInterrupt
        elif self._held and self._old == signal.SIG_DFL:
            raise KeyboardInterrupt
        return False

