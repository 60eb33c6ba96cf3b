"""``torch.no_grad`` as a method decorator for the control loop's calls.

The training loop runs under ``torch.inference_mode`` (gradients already off), where
``@torch.no_grad()`` still builds and enters a grad-mode context on every call: about 3 us
on the shared 2-core VM, a few calls every step. :func:`no_grad` switches gradients off
only when they are on, which is the same effect.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import torch

__all__ = ["no_grad"]

F = TypeVar("F", bound=Callable[..., Any])


def no_grad(fn: F) -> F:
    """``fn`` with gradients off (as ``@torch.no_grad()``; no context when already off)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if not torch.is_grad_enabled():
            return fn(*args, **kwargs)
        with torch.no_grad():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
