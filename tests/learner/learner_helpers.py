"""Hand-made observations, neurons and transitions for the learner tests (no env needed)."""

from __future__ import annotations

import weakref

import torch
from tensordict import TensorDict

from symrl.assembly import build_policy, build_update
from symrl.learner.config import RunConfig, load_config
from symrl.learner.policy import MixtureOfExpertsPolicy
from symrl.learner.update import TeseoUpdate

N_SENSORS = 24

# One odometry pose per region of the hailu2001 map.
POSES = {
    "room": (0.0, 0.0, 0.0),
    "concave": (1.0, -2.0, 0.0),
    "door": (3.6, -0.5, 0.0),
    "corridor": (4.5, 0.5, 0.0),
}


def config(recipe: str = "paper_literal", *overrides: str) -> RunConfig:
    """The recipe with map localisation off unless an override turns it on: the hand-made
    observations here are not scans of the map, so a localiser would move their poses."""
    named = any(o.startswith("localize.enabled=") for o in overrides)
    return load_config(recipe, [*([] if named else ["localize.enabled=false"]), *overrides])


_CONFIGS: weakref.WeakKeyDictionary[MixtureOfExpertsPolicy, RunConfig] = weakref.WeakKeyDictionary()


def policy(recipe: str = "paper_literal", *overrides: str, seeds=(0,)) -> MixtureOfExpertsPolicy:
    """The recipe's policy of robots ``seeds``, as the assembly builds it."""
    cfg = config(recipe, *overrides)
    p = build_policy(cfg, None, list(seeds))
    _CONFIGS[p] = cfg
    return p


def config_of(p: MixtureOfExpertsPolicy) -> RunConfig:
    """The config :func:`policy` built ``p`` from."""
    return _CONFIGS[p]


def teseo(p: MixtureOfExpertsPolicy) -> TeseoUpdate:
    """The update of a policy from :func:`policy`, as the assembly builds it."""
    return build_update(config_of(p), p)


def act(p: MixtureOfExpertsPolicy, td: TensorDict) -> TensorDict:
    """The policy acting on ``td`` perceived by its perception transform (called directly, as
    an env with the transform appended writes its keys)."""
    return p(p.perception_transform()(td))


def observation(
    sonar: float | list[float] = 0.5,
    pose: tuple[float, float, float] = POSES["room"],
    goal: tuple[float, float] = (4.0, 0.0),
    state_reward: float = -0.1,
    ir: torch.Tensor | None = None,
    batch: int = 1,
) -> TensorDict:
    """A batch of identical observations; ``sonar`` a constant or 24 normalised values."""
    s = torch.full((N_SENSORS,), sonar) if isinstance(sonar, float) else torch.tensor(sonar)
    ir = torch.zeros(N_SENSORS) if ir is None else ir
    rows = {
        "sonar": s.float(),
        "ir": ir.float(),
        "odometry": torch.tensor(pose, dtype=torch.float32),
        "goal": torch.tensor(goal, dtype=torch.float32),
        "state_reward": torch.tensor([state_reward], dtype=torch.float32),
    }
    return TensorDict({k: v.expand(batch, *v.shape).clone() for k, v in rows.items()}, [batch])


def stack(*tds: TensorDict) -> TensorDict:
    """One batch of B observations from B one-robot observations."""
    return torch.cat(list(tds), 0)


def place(
    p: MixtureOfExpertsPolicy,
    obs: TensorDict,
    action: float = 0.0,
    utility: float = 0.0,
    mean: float = 0.0,
    row: int = 0,
) -> int:
    """Add a neuron at the state ``obs`` (robot ``row``) of the expert the gate picks there;
    returns its index."""
    per = _perceive(p, obs, row)
    index = p.experts.add(
        torch.tensor([row]),
        per["expert"],
        per["x"],
        torch.tensor([action], dtype=torch.float64),
        torch.tensor([utility], dtype=torch.float64),
    )
    p.experts.means[row, int(per["expert"][0]), int(index[0])] = mean
    return int(index[0])


def _perceive(p: MixtureOfExpertsPolicy, obs: TensorDict, row: int) -> dict[str, torch.Tensor]:
    """The policy's perception of robot ``row`` at the state ``obs`` (one row), as (1,) rows."""
    full = obs[:1].expand(p.batch).clone()
    per = p.perceive(full["sonar"], full["odometry"], full["goal"])
    return {name: getattr(per, name)[row : row + 1] for name in per._fields}


def transition(
    p: MixtureOfExpertsPolicy,
    now: TensorDict,
    nxt: TensorDict,
    reward: float,
    *,
    row: int = 0,
    winner: int | None = None,
    x: torch.Tensor | None = None,
    novel: bool = False,
    proto: float = 0.0,
    xi: float = 0.0,
    taken: float = 0.0,
    option_entry: bool = False,
    terminated: bool = False,
    truncated: bool = False,
) -> TensorDict:
    """The one-robot transition a Collector would yield, its decision keys written by hand:
    the update reads exactly these keys. ``winner`` defaults to robot ``row``'s nearest neuron
    at ``now``; :func:`torch.cat` the transitions of every robot for a batch."""
    per = _perceive(p, now, row)
    if winner is None:
        winner = int(per["winner"][0])
    td = TensorDict(
        {
            "expert": per["expert"],
            "region": per["region"],
            "winner": torch.tensor([-1 if novel else winner]),
            "novel": torch.tensor([novel]),
            "x": per["x"] if x is None else x.reshape(1, -1),
            "proto": torch.tensor([proto], dtype=torch.float64),
            "xi": torch.tensor([xi], dtype=torch.float64),
            "taken": torch.tensor([taken], dtype=torch.float64),
            "option_entry": torch.tensor([option_entry]),
            "state_reward": now["state_reward"],
        },
        [1],
    )
    full = nxt[:1].expand(p.batch).clone()
    seen = p.perception_transform().perceive(full["sonar"], full["odometry"], full["goal"])
    nxt = nxt.select("sonar", "ir", "odometry", "goal", "state_reward").clone()
    nxt.update({key: value[row : row + 1] for key, value in seen.items()})  # its perception
    nxt["reward"] = torch.tensor([[reward]], dtype=torch.float32)
    nxt["terminated"] = torch.tensor([[terminated]])
    nxt["truncated"] = torch.tensor([[truncated]])
    nxt["done"] = torch.tensor([[terminated or truncated]])
    td["next"] = nxt
    return td


def whole_and_resumed(tmp_path, args: list[str], trials: int, stop: int) -> tuple[list, list]:
    """The trial tables of ``symrl train paper ARGS`` run ``trials`` trials at once, and run
    ``stop`` trials then resumed to ``trials`` (both in folders under ``tmp_path``)."""
    from symrl.cli import main
    from symrl.runs import read_trials_csv

    whole, parted = tmp_path / "whole", tmp_path / "parted"
    assert main(["train", "paper", "--trials", str(trials), "--logdir", str(whole), *args]) == 0
    assert main(["train", "paper", "--trials", str(stop), "--logdir", str(parted), *args]) == 0
    assert main(["train", "--resume", str(parted), "--trials", str(trials)]) == 0
    return read_trials_csv(whole / "trials.csv"), read_trials_csv(parted / "trials.csv")


def paper_trials(world: str, seed: int, trials: int, *overrides: str) -> list[dict]:
    """The trial rows of `paper` (with ``overrides``) on ``world``, seed ``seed``."""
    from symrl.studies.runner import resolve_config
    from symrl.train import train_batch

    config = resolve_config("paper", [f"env.map={world}", f"run.trials={trials}", *overrides])
    (result,) = train_batch(config, [seed], progress=False)
    return list(result.trials)
