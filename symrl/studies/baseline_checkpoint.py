"""A baseline's checkpoint: the trained actor (a self-contained controller that ``symrl
evaluate`` drives, :func:`load_baseline`) and the run state ``symrl baseline --resume`` goes on
from (:func:`load_run_state`, checked against the run's settings and knowledge)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from symrl.learner.config import RunConfig, config_to_dict
from symrl.studies.actor import make_actor
from symrl.studies.baseline_agent import Algorithm
from symrl.studies.baseline_env import make_env
from symrl.studies.priors import PriorAction, Priors

__all__ = [
    "CHECKPOINT_KIND",
    "SNAPSHOT_FORMAT",
    "save_baseline",
    "load_run_state",
    "knowledge_of",
    "BaselineController",
    "load_baseline",
]

CHECKPOINT_KIND = "baseline"
SNAPSHOT_FORMAT = 1
"""Format of the run state a baseline checkpoint holds (``symrl baseline ... --resume``)."""


def save_baseline(
    path: Path,
    algorithm: str,
    agent: Algorithm,
    priors: Priors,
    config: RunConfig,
    world: Any,
    seed: int,
    n_obs: int,
    resume: dict[str, Any] | None = None,
) -> None:
    """The actor, how to rebuild it, the priors, config and map content: self-contained; with
    ``resume`` also the run state to go on from (:func:`load_run_state`). Written atomically: a
    crash leaves the previous file."""
    from symrl.about import provenance
    from symrl.runs import CHECKPOINT_FORMAT, atomic_save, map_content

    atomic_save(
        {
            **({"resume": resume} if resume is not None else {}),
            "format": CHECKPOINT_FORMAT,
            "kind": CHECKPOINT_KIND,
            "algorithm": algorithm,
            "provenance": provenance(),
            "priors": asdict(priors),
            "actor_spec": {"n_obs": n_obs, **agent.actor_spec},
            "config": config_to_dict(config),
            "map": map_content(world),
            "seed": int(seed),
            "actor": agent.actor.state_dict(),
        },
        path,
    )


def load_run_state(
    logdir: str | Path,
    settings: dict[str, Any],
    episodes: int,
    knowledge: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The run state in ``logdir/checkpoint.pt`` to go on to ``episodes`` trials, checked
    against this run's ``settings`` (algorithm, priors, seed, robots, hyper-parameters) and
    ``knowledge`` (the ``env``, ``reflex`` and ``shield`` sections it would use, checked against
    the run's ``config.yaml``: a recipe changed since the run started must not go on silently
    with another reflex). Every fault is one line naming the folder: no run there, no run
    state, another format, other settings or knowledge, a budget below what is done."""
    from symrl.runs import CheckpointError, read_checkpoint_file

    folder = Path(logdir)
    path = folder / "checkpoint.pt"
    if not path.is_file():
        raise CheckpointError(f"--resume {str(folder)!r}: no checkpoint.pt in it")
    data = read_checkpoint_file(path, f"--resume {str(folder)!r}")
    state = data.get("resume") if isinstance(data, dict) else None
    if not isinstance(data, dict) or data.get("kind") != CHECKPOINT_KIND:
        raise CheckpointError(f"--resume {str(folder)!r}: not a baseline run")
    if not isinstance(state, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: the checkpoint holds the actor only, "
            "no run state to go on from"
        )
    if state.get("format") != SNAPSHOT_FORMAT:
        raise CheckpointError(
            f"--resume {str(folder)!r}: run state format {state.get('format')!r}, this symrl "
            f"resumes format {SNAPSHOT_FORMAT}"
        )
    saved, given = _flat(state.get("settings", {})), _flat(settings)
    if knowledge is not None:
        recorded = _config_yaml(folder)
        saved.update(_flat({k: recorded.get(k) for k in knowledge}))
        given.update(_flat(yaml.safe_load(yaml.safe_dump(knowledge))))  # as config.yaml has it
    for key in sorted(set(saved) | set(given)):
        if saved.get(key) != given.get(key):
            raise CheckpointError(
                f"--resume {str(folder)!r}: the run has {key} {saved.get(key)!r}, this command "
                f"{given.get(key)!r}"
            )
    done = len(state["rows"])
    if episodes < done:
        raise ValueError(
            f"--episodes {episodes}: the run in {str(folder)!r} has done {done} trials already"
        )
    return state


def _config_yaml(folder: Path) -> dict[str, Any]:
    """The run's ``config.yaml`` as written at its start (empty if missing or unreadable)."""
    try:
        doc = yaml.safe_load((folder / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return {}
    return doc if isinstance(doc, dict) else {}


def knowledge_of(config: RunConfig, priors: Priors | None = None) -> dict[str, Any]:
    """The world and knowledge sections of ``config``: ``env``, ``reflex`` and ``shield``;
    with ``priors`` only those a run with them uses (the reflex and the shield act only in a
    residual run)."""
    tree = config_to_dict(config)
    used = ("env", "reflex", "shield") if priors is None or priors.residual else ("env",)
    return {key: tree[key] for key in used}


def _flat(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested settings as ``{"ppo.hidden": 64, ...}`` (an error names the one that differs)."""
    out: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


class BaselineController(TensorDictModuleBase):
    """A trained baseline as a controller of B robots: actor, then :class:`PriorAction`.

    Has the two things :func:`symrl.evaluate.rollout` asks of a controller (``batch``,
    ``begin_trial``); greedy under TorchRL's DETERMINISTIC exploration type (the actor's mode).
    """

    def __init__(
        self,
        actor: Any,
        priors: Priors,
        config: RunConfig,
        world: Any,
        algorithm: str,
        batch: int = 1,
    ) -> None:
        super().__init__()
        self.actor, self.priors, self.config, self.world = actor, priors, config, world
        self.algorithm, self.batch = algorithm, batch
        self.to_action = PriorAction(priors, config)
        self.in_keys = ["observation", *self.to_action.in_keys[1:]]
        self.out_keys = ["control", "action", "shielded"]

    def begin_trial(self, rows: torch.Tensor) -> None:
        """Nothing to forget between trials (no per-trial state)."""

    @torch.no_grad()
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        self.actor(td)
        return self.to_action(td)

    def evaluate(
        self, starts: Sequence[Any] | None = None, seed: int = 0, world: Any = None
    ) -> list[dict[str, Any]]:
        """One greedy trial from each start (radians; None: the map's start), noise on."""
        from symrl.evaluate import rollout

        starts = list(starts) if starts else [None]
        world = world if world is not None else self.world
        if self.priors.regions and len(world.regions.names) != len(self.world.regions.names):
            raise ValueError(
                f"--map {world.name}: {len(world.regions.names)} regions, the controller was "
                f"trained with a one-hot of {len(self.world.regions.names)}"
            )
        env = make_env(self.config, self.priors, [seed + k for k in range(len(starts))], world)
        if any(s is not None for s in starts):
            home = (world.start.x, world.start.y, world.start.heading)
            env.base_env.set_starts(np.array([s if s is not None else home for s in starts]))
        self.batch = len(starts)
        try:
            return rollout(self, env)
        finally:
            env.close()


def load_baseline(path: str | Path) -> BaselineController | None:
    """The controller in a baseline checkpoint; None if the file is another kind (the paper
    learner's, read by :func:`symrl.runs.load_checkpoint`). Faults: one-line CheckpointError."""
    from symrl.learner.config import ConfigError, config_from_dict
    from symrl.runs import CheckpointError
    from symrl.world.worldmap import MapError, load_map

    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # noqa: BLE001 - load_checkpoint reports unreadable files
        return None
    if not isinstance(data, dict) or data.get("kind") != CHECKPOINT_KIND:
        return None
    try:
        config = config_from_dict(dict(data["config"]), recipe="paper_map")
        world = load_map(data["map"]) if data.get("map") else load_map(config.env.map)
        priors = Priors(**data["priors"])
        spec = dict(data["actor_spec"])
        actor = make_actor(int(spec["n_obs"]), spec["cells"], spec["activation"])
        actor.load_state_dict(data["actor"])
    except (ConfigError, MapError) as err:
        raise CheckpointError(f"checkpoint {str(path)!r}: {err}") from None
    except (KeyError, TypeError, RuntimeError) as err:
        detail = str(err).splitlines()[0][:160] if str(err) else type(err).__name__
        raise CheckpointError(
            f"checkpoint {str(path)!r}: not a usable baseline ({detail})"
        ) from None
    return BaselineController(actor, priors, config, world, str(data.get("algorithm")))
