"""A command run as its own process (``symrl ...``): what it imports, and when, so that it
starts fast."""

from __future__ import annotations

import sys


def set_up(command: str) -> None:
    """Keep Ray out (unless the command is ``sweep``), start the figure-drawing process of a
    ``study`` and import what ``command`` needs with the garbage collector paused."""
    if command != "sweep":
        _without_ray()
    if command == "study":  # its figures: drawn by a process importing matplotlib now
        from symrl import drawing

        drawing.start()
    _preload(command)


def _without_ray() -> None:
    """Keep Ray out of this process: torchrl imports it at import time whenever it is
    installed (its Ray replay buffer), which is about a quarter of the import time of every
    command (``python -X importtime``); only ``symrl sweep --backend ray`` uses it."""
    sys.modules.setdefault("ray", None)  # type: ignore[arg-type]  # `import ray` now fails


_TRAINING = ("symrl.train", "symrl.learner.policy", "symrl.learner.loss", "symrl.world.batched_env")
_PRELOAD = {
    "train": (*_TRAINING, "symrl.runs"),
    "evaluate": (*_TRAINING, "symrl.evaluate", "symrl.figures"),
    "study": (*_TRAINING, "symrl.studies.repeatability"),  # matplotlib: in symrl.drawing's process
    "ablate": (*_TRAINING, "symrl.studies.ablation", "symrl.figures"),
    "generalise": (*_TRAINING, "symrl.studies.generalisation", "symrl.figures"),
}
"""The modules a command imports anyway (torch, tensordict, torchrl, matplotlib under them)."""


def _preload(command: str) -> None:
    """Import what ``command`` needs with the garbage collector paused, then freeze those
    objects out of later collections: the imports create about 450,000 long-lived objects,
    and collecting while they arrive (full passes over all of them, several times) cost
    about 0.6 s of the import time here (measured with and without ``gc.disable()``)."""
    import gc
    import importlib

    modules = _PRELOAD.get(command, ())
    if not modules:
        return
    gc.disable()
    try:
        for name in modules:
            importlib.import_module(name)
    finally:
        gc.freeze()
        gc.enable()
