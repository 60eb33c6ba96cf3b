"""``TeseoLoss``: the name scripts and notebooks written against earlier releases import the
TESEO update by. It is :class:`symrl.learner.update.TeseoUpdate` (not a TorchRL
``LossModule``: nothing is differentiated)."""

from __future__ import annotations

from symrl.learner.update import TeseoUpdate

__all__ = ["TeseoLoss"]

TeseoLoss = TeseoUpdate
