"""A run's checkpoint: the controller, its config, seed and map content, and the run state to
resume from (``symrl train --resume``); written atomically, and every fault of a file read
back is a one-line :class:`CheckpointError`."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import torch
import yaml

from symrl.learner.config import ConfigError, RunConfig, config_from_dict, config_to_dict
from symrl.learner.config.baselines import used_settings
from symrl.runs.policy_check import check_policy_state
from symrl.runs.tables import flat

CHECKPOINT_FORMAT = 3
"""3: the controller's learned counters under ``progress.`` and its option critic under
``options.critic.`` (format 2 held them at the top and under ``options.``)."""


class CheckpointError(ValueError):
    """A checkpoint file cannot be used; the message names the file and the fault."""


def atomic_save(obj: Any, path: Path) -> None:
    """torch.save to a temporary file in the same folder, then rename: never half a file."""
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        torch.save(obj, tmp)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a run's files are readable alike
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def map_content(world: Any) -> dict[str, Any] | None:
    """The map file's parsed content, so a checkpoint does not depend on the file staying."""
    source = Path(str(getattr(world, "source", "")))
    if source.is_file():
        return yaml.safe_load(source.read_text())
    return None


def save_checkpoint(
    path: str | Path,
    policy: Any,
    config: RunConfig,
    seed: int,
    resume: dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    world: Any = None,
) -> None:
    """The controller of one robot (a B = 1 policy), its config, seed and map content; with
    ``resume`` (a :func:`symrl.train.run_snapshot`) also the whole run state, so that
    ``symrl train --resume`` can go on from it (``load_checkpoint`` ignores it)."""
    path = Path(path)
    if provenance is None:
        from symrl.about import provenance as current

        provenance = current()
    data = {
        "format": CHECKPOINT_FORMAT,
        "provenance": provenance,
        "config": config_to_dict(config),
        "map": map_content(world),
        "seed": int(seed),
        "policy": resume["policy"] if resume is not None else policy.state_dict(),
    }
    if resume is not None:
        data["resume"] = resume
    atomic_save(data, path)


def load_resume(run_dir: str | Path, adopt: bool = False) -> tuple[RunConfig, int, dict[str, Any]]:
    """``(config, seed, state)`` of the run in folder ``run_dir`` to resume it; every fault
    (no such folder, no checkpoint, a checkpoint without run state or of another format, a
    checkpoint whose recipe, seed, map or settings differ from the folder's ``config.yaml``
    unless ``adopt``) is a one-line :class:`CheckpointError`."""
    from symrl.train import SNAPSHOT_FORMAT

    folder = Path(run_dir)
    if folder.exists() and not folder.is_dir():
        raise CheckpointError(f"--resume {str(folder)!r}: is a file; pass the run folder")
    if not folder.is_dir():
        raise CheckpointError(f"--resume {str(folder)!r}: no such run folder")
    path = folder / "checkpoint.pt"
    if not path.is_file():
        raise CheckpointError(f"--resume {str(folder)!r}: no checkpoint.pt in it")
    _, config = load_checkpoint(path)  # checks format, config, map and weights
    data = torch.load(path, map_location="cpu", weights_only=True)
    state = data.get("resume")
    if not isinstance(state, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: checkpoint.pt holds a controller only, no run state "
            "to resume from"
        )
    if state.get("format") != SNAPSHOT_FORMAT:
        raise CheckpointError(
            f"--resume {str(folder)!r}: run state format {state.get('format')!r}, this symrl "
            f"resumes format {SNAPSHOT_FORMAT}"
        )
    seed = int(data["seed"])
    if not adopt:
        check_same_run(folder, config, seed)
    return config, seed, state


def check_same_run(folder: Path, config: RunConfig, seed: int) -> None:
    """The checkpoint of ``folder`` belongs to the run its ``config.yaml`` records: the same
    settings its learner reads (the trial budget aside, which ``--trials`` may extend) and
    seed; else a one-line :class:`CheckpointError`. A setting the recorded file lacks was
    added to symrl after the run was written (the checkpoint's config has its default)."""
    recorded_file = folder / "config.yaml"
    if not recorded_file.is_file():
        return
    try:
        recorded = yaml.safe_load(recorded_file.read_text())
    except (OSError, yaml.YAMLError, UnicodeDecodeError):
        recorded = None
    if not isinstance(recorded, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: config.yaml is not readable, so checkpoint.pt cannot be "
            "checked against it; pass --adopt-checkpoint to go on with the checkpoint's config"
        )
    saved = flat(used_settings(config, config_to_dict(config)))
    saved["run.seed"] = seed
    have = flat({k: v for k, v in recorded.items() if k != "provenance"})
    for key in ("recipe", "run.seed", "env.map", *sorted(set(saved) | set(have))):
        if key == "run.trials" or saved.get(key) == have.get(key):
            continue
        if key not in have and key in saved:  # a setting newer than the run
            continue
        raise CheckpointError(
            f"--resume {str(folder)!r}: checkpoint.pt has {key}={saved.get(key)!r} but the "
            f"folder's config.yaml {key}={have.get(key)!r}: not this folder's run; pass "
            "--adopt-checkpoint to go on with the checkpoint's run"
        )


def read_checkpoint_file(path: Path, name: str) -> Any:
    """The content of the checkpoint file ``path`` (tensors and plain values only); a file
    that cannot be read is a one-line :class:`CheckpointError` that starts with ``name``."""
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # noqa: BLE001 - any unreadable file is the same user error
        detail = str(err).splitlines()[0][:120] if str(err) else type(err).__name__
        raise CheckpointError(f"{name}: not a readable symrl checkpoint ({detail})") from None


def load_checkpoint(path: str | Path) -> tuple[Any, RunConfig]:
    """Rebuild ``(policy, config)`` from :func:`save_checkpoint`; every fault of the file is a
    one-line :class:`CheckpointError`."""
    policy, config, _ = load_checkpoint_world(path)
    return policy, config


def load_checkpoint_world(path: str | Path) -> tuple[Any, RunConfig, Any]:
    """:func:`load_checkpoint` and the world the robot learned in (the checkpoint's map; the
    policy holds only what its recipe's ``knowledge`` tells it)."""
    from symrl.assembly import build_policy
    from symrl.world.worldmap import MapError, load_map

    path = Path(path)
    if path.is_dir():
        raise CheckpointError(
            f"checkpoint {str(path)!r}: is a folder; pass the checkpoint.pt file in it"
        )
    if not path.exists():
        raise CheckpointError(f"checkpoint {str(path)!r}: no such file")
    if not path.is_file():
        raise CheckpointError(
            f"checkpoint {str(path)!r}: not a regular file (a device, pipe or socket); pass the "
            "checkpoint.pt a run wrote"
        )
    data = read_checkpoint_file(path, f"checkpoint {str(path)!r}")
    if not isinstance(data, dict) or "config" not in data or "policy" not in data:
        raise CheckpointError(f"checkpoint {str(path)!r}: not written by symrl train")
    if data.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(
            f"checkpoint {str(path)!r}: format {data.get('format')!r}, this symrl reads "
            f"format {CHECKPOINT_FORMAT}"
        )
    kinds = (("config", dict), ("policy", dict), ("seed", int))
    for key, kind in kinds:
        value = data.get(key, 0 if key == "seed" else None)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise CheckpointError(
                f"checkpoint {str(path)!r}: {key} must be a {kind.__name__}, got "
                f"{type(value).__name__}"
            )
    try:
        cfg = dict(data["config"])
        config = config_from_dict(cfg, recipe=str(cfg.get("recipe", "checkpoint")))
        world = load_map(data["map"]) if data.get("map") else load_map(config.env.map)
    except (ConfigError, MapError) as err:
        raise CheckpointError(f"checkpoint {str(path)!r}: {err}") from None
    policy = build_policy(config, world, [int(data.get("seed", config.run.seed))])
    state = data["policy"]
    fault = check_policy_state(state, policy.state_dict())
    if fault:
        raise CheckpointError(f"checkpoint {str(path)!r}: {fault}")
    try:
        policy.load_state_dict(state)
    except (RuntimeError, KeyError, TypeError) as err:
        lines = [line.strip() for line in str(err).splitlines() if line.strip()]
        detail = (lines[1] if len(lines) > 1 else lines[0] if lines else type(err).__name__)[:200]
        raise CheckpointError(
            f"checkpoint {str(path)!r}: weights do not match its config ({detail})"
        ) from None
    return policy, config, world
