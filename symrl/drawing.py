"""Figures drawn by a process of their own, forked when a command starts.

A study spends about 1.4 s importing torch, tensordict and torchrl on one core before it
trains; matplotlib and a process's first figure (its fonts and canvas) are another 0.25 s.
``symrl study`` therefore forks a drawing process first (:func:`start`): it imports matplotlib
and draws a warm-up figure on the other core while this process imports torch, then waits for
figures. :func:`draw` sends it a list of figures, each a function of
``symrl.figures`` named with its arguments, and returns when they are written (the drawing
process shares them out over the cores with ``symrl.figures.draw_in_parallel``). Without a
drawing process (not started, not Linux, or it died) the figures are drawn here, the same
files either way.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["Figure", "start", "stop", "draw"]

Figure = tuple[str, tuple[Any, ...], dict[str, Any]]
"""A figure to draw: the name of a ``symrl.figures`` function, its positional and keyword
arguments (picklable: they travel to the drawing process)."""

_process: Any = None
_connection: Any = None


def start() -> None:
    """Fork the drawing process (Linux only; nothing if one runs already)."""
    global _process, _connection
    if _process is not None or not sys.platform.startswith("linux"):
        return
    import atexit
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    _connection, theirs = ctx.Pipe()
    # not a daemon: it forks helpers of its own; it ends when the pipe closes, which
    # `stop` does at exit, before multiprocessing joins its children
    _process = ctx.Process(target=_serve, args=(theirs, _connection), name="symrl-drawing")
    _process.start()
    theirs.close()
    atexit.register(stop)


def stop() -> None:
    """End the drawing process (it also ends with this one)."""
    global _process, _connection
    if _process is None:
        return
    _connection.close()
    _process.join(timeout=5)
    if _process.is_alive():
        _process.terminate()
    _process = _connection = None


def draw(figures: Sequence[Figure]) -> None:
    """Draw ``figures`` in the drawing process if one runs, else here. An error in a figure
    function is raised here: as itself when drawn here, as a RuntimeError carrying the
    drawing process's traceback otherwise."""
    if _process is not None and not _process.is_alive():
        stop()
    if _process is not None:
        try:
            _connection.send(list(figures))
            failure = _connection.recv()
        except (EOFError, OSError):  # the process has gone: draw them here instead
            stop()
        else:
            if failure is not None:
                raise RuntimeError(f"drawing the figures failed:\n{failure}")
            return
    _draw_here(figures)


def _draw_here(figures: Sequence[Figure]) -> None:
    from symrl import figures as F

    F.draw_in_parallel(
        [functools.partial(getattr(F, name), *args, **kwargs) for name, args, kwargs in figures]
    )


def _serve(connection: Any, commands_end: Any) -> None:
    """The drawing process: import matplotlib now, then draw what arrives until the command
    closes its end of the pipe (``commands_end``, whose copy the fork gave this process too,
    closed here so that the command's close ends the pipe)."""
    import traceback

    commands_end.close()
    try:
        _warm_up()
        while True:
            try:
                figures = connection.recv()
            except (EOFError, OSError):
                return
            try:
                _draw_here(figures)
            except Exception:  # noqa: BLE001 - sent back, raised by the caller
                connection.send(traceback.format_exc())
            else:
                connection.send(None)
    except KeyboardInterrupt:  # Ctrl-C reaches the whole process group: the command reports it
        return


def _warm_up() -> None:
    """Import matplotlib and the map drawing, and draw one small figure to memory: a process's
    first figure also loads the fonts and the Agg canvas, which this one does now, in
    parallel with the command's own imports, instead of when the figures are due."""
    import io

    from symrl import figures as F
    from symrl.world import render  # noqa: F401 - imported by the map panels when they draw

    fig, ax = F.plt.subplots(figsize=(2.0, 2.0))
    ax.plot([0.0, 1.0], [0.0, 1.0], marker="o", label="warm-up")
    ax.set_title("warm-up")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(io.BytesIO(), format="png")
    F.plt.close(fig)
