"""The deep-RL baselines' actor network, shared by :mod:`symrl.studies.sac` and
:mod:`symrl.studies.ppo` (their common loop, :mod:`symrl.studies.baseline`, drives either)."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["make_actor"]


def make_actor(n_obs: int, cells: Sequence[int], activation: str):
    """TanhNormal actor on [-1, 1] over ``observation``, writing ``control`` and its log-prob."""
    from tensordict.nn import NormalParamExtractor, TensorDictModule
    from torch import nn
    from torchrl.data import Bounded
    from torchrl.modules import MLP, ProbabilisticActor, TanhNormal

    act = {"relu": nn.ReLU, "tanh": nn.Tanh}[activation]
    net = nn.Sequential(
        MLP(in_features=n_obs, out_features=2, num_cells=list(cells), activation_class=act),
        NormalParamExtractor(),
    )
    return ProbabilisticActor(
        TensorDictModule(net, in_keys=["observation"], out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"],
        out_keys=["control"],
        spec=Bounded(-1.0, 1.0, (1,)),
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True,
    )
