"""A baseline's checkpoint: the trained actor with the run's config and map (a self-contained
controller that ``symrl evaluate`` drives, :func:`load_baseline`) and the run state ``symrl
train --resume`` goes on from (:func:`load_baseline_resume`, checked against the folder's
``config.yaml``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from symrl.learner.config import RunConfig, config_to_dict
from symrl.studies.actor import make_actor
from symrl.studies.baseline_agent import Algorithm
from symrl.studies.baseline_env import make_env
from symrl.studies.priors import PriorAction, Priors, priors_of

__all__ = [
    "CHECKPOINT_KIND",
    "SNAPSHOT_FORMAT",
    "save_baseline",
    "is_baseline_checkpoint",
    "load_baseline_resume",
    "BaselineController",
    "load_baseline",
]

CHECKPOINT_KIND = "baseline"
SNAPSHOT_FORMAT = 2
"""Format of the run state a baseline checkpoint holds (2: the run's whole config, the trial
rows under ``trials``)."""


def save_baseline(
    path: Path,
    agent: Algorithm,
    config: RunConfig,
    world: Any,
    n_obs: int,
    resume: dict[str, Any] | None = None,
) -> None:
    """The actor, how to rebuild it, the config and the map's content: self-contained; with
    ``resume`` also the run state to go on from (:func:`load_baseline_resume`). Written
    atomically: a crash leaves the previous file."""
    from symrl.about import provenance
    from symrl.runs import CHECKPOINT_FORMAT, atomic_save, map_content

    atomic_save(
        {
            **({"resume": resume} if resume is not None else {}),
            "format": CHECKPOINT_FORMAT,
            "kind": CHECKPOINT_KIND,
            "algorithm": config.baseline.algorithm,
            "provenance": provenance(),
            "actor_spec": {"n_obs": n_obs, **agent.actor_spec},
            "config": config_to_dict(config),
            "map": map_content(world),
            "seed": int(config.run.seed),
            "actor": agent.actor.state_dict(),
        },
        path,
    )


def is_baseline_checkpoint(path: str | Path) -> bool:
    """Whether the file ``path`` is a baseline's checkpoint (False for anything else, an
    unreadable file included: the paper learner's loader reports those)."""
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # noqa: BLE001 - the other loader names the fault
        return False
    return isinstance(data, dict) and data.get("kind") == CHECKPOINT_KIND


def load_baseline_resume(
    run_dir: str | Path, adopt: bool = False
) -> tuple[RunConfig, int, dict[str, Any], Any]:
    """``(config, seed, state, world)`` of the baseline run in folder ``run_dir`` to go on with
    it; every fault (no run state, another format, a checkpoint whose settings differ from the
    folder's ``config.yaml`` unless ``adopt``) is a one-line CheckpointError."""
    from symrl.runs import CheckpointError, check_same_run, read_checkpoint_file

    folder = Path(run_dir)
    name = f"--resume {str(folder)!r}"
    controller = load_baseline(folder / "checkpoint.pt")
    if controller is None:
        raise CheckpointError(f"{name}: not a baseline run")
    data = read_checkpoint_file(folder / "checkpoint.pt", name)
    state = data.get("resume")
    if not isinstance(state, dict):
        raise CheckpointError(
            f"{name}: the checkpoint holds the actor only, no run state to go on from"
        )
    if state.get("format") != SNAPSHOT_FORMAT:
        raise CheckpointError(
            f"{name}: run state format {state.get('format')!r}, this symrl resumes format "
            f"{SNAPSHOT_FORMAT}"
        )
    config = controller.config
    if not adopt:
        check_same_run(folder, config, config.run.seed)
    return config, config.run.seed, state, controller.world


class BaselineController(TensorDictModuleBase):
    """A trained baseline as a controller of B robots: actor, then :class:`PriorAction`.

    Has the two things :func:`symrl.evaluate.rollout` asks of a controller (``batch``,
    ``begin_trial``); greedy under TorchRL's DETERMINISTIC exploration type (the actor's mode).
    """

    def __init__(self, actor: Any, config: RunConfig, world: Any, batch: int = 1) -> None:
        super().__init__()
        self.actor, self.config, self.world, self.batch = actor, config, world, batch
        self.priors: Priors = priors_of(config)
        self.algorithm = config.baseline.algorithm
        self.to_action = PriorAction(self.priors, config)
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
        env = make_env(self.config, [seed + k for k in range(len(starts))], world)
        if any(s is not None for s in starts):
            home = (world.start.x, world.start.y, world.start.heading)
            env.base_env.set_starts(np.array([s if s is not None else home for s in starts]))
        self.batch = len(starts)
        try:
            return rollout(self, env)
        finally:
            env.close()


def earlier_format(data: dict[str, Any]) -> dict[str, Any]:
    """The run config of a baseline checkpoint, also of one written before baselines were
    recipes: that kept the algorithm and its priors beside the map rung's whole config, whose
    env, reflex and shield the controller was trained with. Its ``baseline`` section is rebuilt
    from them, told what its priors used (the regions rung with the one-hot, else the sensors),
    with nothing of the paper's learner switched on."""
    config = dict(data["config"])
    if "baseline" in config or "algorithm" not in data or "priors" not in data:
        return config
    priors = dict(data["priors"])
    residual, regions = bool(priors.get("residual")), bool(priors.get("regions"))
    section: dict[str, Any] = {"algorithm": data["algorithm"], "residual": residual}
    section["regions"] = regions
    if residual:
        section["correction"] = priors.get("correction")
    config["baseline"] = section
    config["knowledge"] = "regions" if regions else "sensors"
    config["gate"] = {**dict(config.get("gate", {})), "partition": False}
    for switched in ("options", "localize", "crossings"):
        config[switched] = {**dict(config.get(switched, {})), "enabled": False}
    config["recipe"] = str(data["algorithm"])
    return config


def load_baseline(path: str | Path) -> BaselineController | None:
    """The controller in a baseline checkpoint; None if the file is another kind (the paper
    learner's, read by :func:`symrl.runs.load_checkpoint`). Faults: one-line CheckpointError."""
    from symrl.learner.config import ConfigError, config_from_dict
    from symrl.runs import CheckpointError
    from symrl.world.worldmap import MapError, load_map

    if not is_baseline_checkpoint(path):
        return None
    data = torch.load(path, map_location="cpu", weights_only=True)
    try:
        config = config_from_dict(earlier_format(data))
        if config.baseline.algorithm is None:
            raise KeyError("baseline.algorithm")
        world = load_map(data["map"]) if data.get("map") else load_map(config.env.map)
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
    return BaselineController(actor, config, world)
