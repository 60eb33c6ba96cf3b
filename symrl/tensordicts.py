"""Reading and writing many entries of a plain TensorDict in the control loop.

TensorDict's public ``get``/``set``/``update`` check every key and value on each call; for the
loop's plain string keys and shapes it builds itself, :func:`read`, :func:`write` and
:func:`tensordict_items` give the same results at a fraction of the cost. They live in
:mod:`symrl.fastpaths` with every other shortcut past a library's checked calls.
"""

from __future__ import annotations

from symrl.fastpaths import read, tensordict_items, write

__all__ = ["read", "write", "tensordict_items"]
