"""How the pipeline holds an interrupt back during an atomic write."""
import os
import signal

import pytest

from pipeline.errors import interrupt_deferred


def test_an_interrupt_inside_the_block_is_raised_when_it_ends():
    """SIGINT delivered inside the block: the block runs to its end, then the
    KeyboardInterrupt comes; the previous handler is back afterwards."""
    runner = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        done = []
        with pytest.raises(KeyboardInterrupt):
            with interrupt_deferred():
                os.kill(os.getpid(), signal.SIGINT)
                done.append("written")
        assert done == ["written"]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, runner)


def test_no_interrupt_no_exception_and_an_ignored_one_stays_ignored():
    with interrupt_deferred():
        pass
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with interrupt_deferred():
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)
