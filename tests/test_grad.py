"""symrl.grad.no_grad: gradients off inside, the caller's mode restored after."""

import torch

from symrl.grad import no_grad


@no_grad
def _inside() -> tuple[bool, torch.Tensor]:
    w = torch.ones(2, requires_grad=True)
    return torch.is_grad_enabled(), w * 2


def test_gradients_are_off_inside_and_restored_after():
    assert torch.is_grad_enabled()
    enabled, y = _inside()
    assert not enabled and not y.requires_grad and torch.is_grad_enabled()
    with torch.inference_mode():
        enabled, y = _inside()
        assert not enabled and not y.requires_grad
    assert _inside.__name__ == "_inside"
