"""Numpy views of a module's buffers, kept between the control loop's calls.

The loop's arithmetic runs in numpy on the tensors' memory (a handful of rows: a numpy call
costs a fraction of a torch op's dispatch), but reaching a buffer costs about 1.4 us on the
shared 2-core VM (``nn.Module.__getattr__`` and ``Tensor.numpy()``), and the loop does that
~15 times a step. :class:`BufferViews` keeps ``{name: buffer.numpy()}`` until a buffer may
have been replaced: any attribute set (a buffer assigned, ``load_state_dict(assign=True)``),
``.to()`` / ``.double()`` (``_apply``), a state dict loaded, a buffer registered, a copy or
a pickle (whose buffers are new tensors). In-place
writes (``buf[rows] = v``, ``load_state_dict``'s copies, numpy writes through the views) keep
the same memory, so the views stay valid.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from torch import nn

__all__ = ["BufferViews"]


class BufferViews(nn.Module):
    """An ``nn.Module`` whose CPU buffers are also readable as numpy arrays: ``self.arrays``.

    The views live in one plain dict, ``self._views`` (an ordinary attribute: ``nn.Module``
    stores a dict as is); a subclass that keeps views of its own derived from the buffers
    (reshaped, say) keeps them there under its own key, and they are dropped with the arrays."""

    def __init__(self) -> None:
        super().__init__()
        self._views: dict[str, Any] = {}

    @property
    def arrays(self) -> dict[str, np.ndarray]:
        """``{name: buffer.numpy()}`` of this module's own buffers (not its children's); the
        arrays share the buffers' memory."""
        views = self._views.get("arrays")
        if views is None:
            views = {name: b.numpy() for name, b in self._buffers.items() if b is not None}
            self._views["arrays"] = views
        return views

    def _forget_arrays(self) -> None:
        views = vars(self).get("_views")  # absent while ``__init__`` runs
        if views:
            views.clear()

    def __setattr__(self, name: str, value: Any) -> None:
        self._forget_arrays()  # a buffer may be replaced: views taken again
        super().__setattr__(name, value)

    def register_buffer(self, name: str, tensor: Any, persistent: bool = True) -> None:
        self._forget_arrays()
        super().register_buffer(name, tensor, persistent)

    def _apply(self, fn, recurse=True):  # .to() / .double(): new tensors, views taken again
        self._forget_arrays()
        return super()._apply(fn, recurse)

    def __getstate__(self) -> dict[str, Any]:  # a copy or a pickle has buffers of its own
        state = dict(super().__getstate__())
        state["_views"] = {}
        return state

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        self._forget_arrays()
        super()._load_from_state_dict(*args, **kwargs)
        self._forget_arrays()
