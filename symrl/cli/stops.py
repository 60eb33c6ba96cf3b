"""Stopping a command: Ctrl-C, SIGTERM and SIGHUP (a closed terminal) end it with its stop
message and its saved progress, never a traceback or a silent death."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator
from typing import Any

RESUMABLE = ("study", "ablate", "sweep")
"""The commands that save their progress as they go and take --resume."""


def stop_signals() -> tuple[int, ...]:
    """Ctrl-C, SIGTERM and (where there is one) SIGHUP: a closed terminal stops a run too. A
    signal the command was started ignoring stays ignored (``nohup`` ignores SIGHUP so that a
    closed terminal does not stop the run)."""
    import signal

    names = ("SIGINT", "SIGTERM", "SIGHUP")
    signals = [getattr(signal, n) for n in names if hasattr(signal, n)]
    return tuple(s for s in signals if signal.getsignal(s) is not signal.SIG_IGN)


def stoppable(run: Callable[[list[int]], Any]) -> int:
    """``run(signalled)`` with SIGINT, SIGTERM and SIGHUP only asking it to stop (``signalled`` gets
    their numbers; the run stops after its current step, with its state saved), from the start
    of the command on."""
    import signal

    signalled: list[int] = []
    handlers = {}

    def on_signal(signum: int, frame) -> None:
        signalled.append(signum)

    for sig in stop_signals():
        handlers[sig] = signal.signal(sig, on_signal)
    try:
        return int(run(signalled))
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, stopping a command as Ctrl-C does."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def signals_stop(on: bool) -> Iterator[None]:
    """With ``on``: Ctrl-C, SIGTERM and SIGHUP stop the command at once, its worker processes
    too (each is sent SIGINT, as a terminal's Ctrl-C does), so it ends with its stop message
    and its saved progress instead of dying silently or waiting for its workers."""
    import os
    import signal

    if not on:
        yield
        return

    def stop(signum: int, frame: Any) -> None:
        import multiprocessing

        if os.getpid() != main_pid:  # a worker forked with this handler: the command reports
            os._exit(128 + signum)  # the stop; its progress is in the files it saved
        for child in multiprocessing.active_children():
            if child.pid is None:  # not started
                continue
            with contextlib.suppress(OSError):
                os.kill(child.pid, signal.SIGINT)
        raise Stopped(signum)

    main_pid = os.getpid()
    old = {s: signal.signal(s, stop) for s in stop_signals()}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


def stopped(command: str, err: KeyboardInterrupt, out: str | None) -> int:
    """Report a command stopped by a signal it does not catch itself (``out``: the folder a
    resumable command saves its progress in); returns the exit code, 128 + the signal."""
    import signal

    signum = int(getattr(err, "signum", signal.SIGINT))
    name = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    if command in RESUMABLE:
        kept = (
            f"its progress is saved in {out}/ (all but the last few seconds); go on "
            "with the same command and --resume"
        )
    else:
        kept = "what was finished is kept"
    print(f"symrl {command}: stopped by {name}; {kept}", file=sys.stderr)
    return 128 + signum
