"""`symrl baseline ppo`: how many trials does a standard deep-RL learner need on the same task?

PPO from TorchRL (``ClipPPOLoss`` + ``GAE``), CleanRL's continuous-control defaults (below), a
TanhNormal actor on [-pi, pi] and a critic, both 2x64 tanh MLPs over the flattened observation:
the 24 normalised sonars plus the goal (distance / 5 m, angle / pi) from odometry - the same
information the paper's controller gets (it codes the distance with 8 Gaussians instead). Same
env (``symrl/Hailu2001-v0``, noise on), same reward, 200-action trials. No prior knowledge.

An *episode* is one trial. Training stops after the first batch that completes ``episodes``
episodes. "Reliable" = at least 80% of the last 20 episodes reached the goal; the report gives
the first episode where that holds, or says it never did within the budget.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["PPOConfig", "run_ppo", "first_reliable", "baseline_command"]


@dataclass
class PPOConfig:
    """PPO hyper-parameters (CleanRL ``ppo_continuous_action.py`` defaults unless noted)."""

    episodes: int = 20
    """Training budget in episodes (trials); the last batch may overshoot it."""
    frames_per_batch: int = 2048
    """Env steps per PPO update (CleanRL num_steps)."""
    epochs: int = 10
    """Passes over each batch (update_epochs)."""
    minibatch: int = 64
    """Transitions per gradient step (2048 / 32 minibatches)."""
    lr: float = 3e-4
    """Adam learning rate."""
    gamma: float = 0.99
    """Discount."""
    lmbda: float = 0.95
    """GAE lambda."""
    clip: float = 0.2
    """PPO clip epsilon."""
    entropy_coef: float = 0.0
    """Entropy bonus (CleanRL: 0)."""
    critic_coef: float = 0.5
    """Value-loss weight."""
    max_grad_norm: float = 0.5
    """Gradient clipping."""
    hidden: int = 64
    """Units per hidden layer (2 layers, tanh)."""
    window: int = 20
    """Episodes in the reliability window."""
    reliable: float = 0.8
    """Success fraction in the window that counts as reliable."""
    seed: int = 100


def first_reliable(reached: list[bool], window: int = 20, level: float = 0.8) -> int | None:
    """First episode (1-based) ending a window of ``window`` episodes with >= level successes."""
    r = np.asarray(reached, dtype=float)
    if len(r) < window:
        return None
    rate = np.convolve(r, np.ones(window), "valid") / window
    hits = np.nonzero(rate >= level - 1e-12)[0]
    return int(hits[0] + window) if len(hits) else None


def make_env(seed: int, map: str = "hailu2001"):
    """The world env (``map``: name or file) through TorchRL's ``GymEnv`` with the flat
    observation PPO reads."""
    import torch
    from torchrl.data import Categorical
    from torchrl.envs import (
        CatTensors,
        Compose,
        GymEnv,
        InitTracker,
        ObservationNorm,
        RewardSum,
        StepCounter,
        TransformedEnv,
    )
    from torchrl.envs.gym_like import default_info_dict_reader

    import symrl

    base = GymEnv(symrl.ENV_ID, noise=True, map=map)
    # the info's collision flag is a bool per step (a spec, else TorchRL assumes float32)
    collision = Categorical(2, (), dtype=torch.bool)
    base.set_info_dict_reader(default_info_dict_reader(["collision"], spec=[collision]))
    env = TransformedEnv(
        base,
        Compose(
            ObservationNorm(
                loc=torch.zeros(2), scale=torch.tensor([1 / 5.0, 1 / math.pi]), in_keys=["goal"]
            ),
            CatTensors(in_keys=["sonar", "goal"], out_key="observation", del_keys=False),
            StepCounter(),
            RewardSum(),
            InitTracker(),
        ),
    )
    env.set_seed(seed)
    return env


def make_modules(env, hidden: int):
    """TanhNormal actor on [-pi, pi] and a value critic, 2x``hidden`` tanh MLPs."""
    import torch
    from tensordict.nn import NormalParamExtractor, TensorDictModule
    from torch import nn
    from torchrl.modules import MLP, ProbabilisticActor, TanhNormal, ValueOperator

    n_obs = env.observation_spec["observation"].shape[-1]
    cells = [hidden, hidden]
    actor_net = nn.Sequential(
        MLP(in_features=n_obs, out_features=2, num_cells=cells, activation_class=nn.Tanh),
        NormalParamExtractor(),
    )
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=["observation"], out_keys=["loc", "scale"]),
        in_keys=["loc", "scale"],
        spec=env.action_spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -math.pi, "high": math.pi},
        return_log_prob=True,
    )
    critic = ValueOperator(
        MLP(in_features=n_obs, out_features=1, num_cells=cells, activation_class=nn.Tanh),
        in_keys=["observation"],
    )
    with torch.no_grad():
        td = env.reset()
        actor(td)
        critic(td)
    return actor, critic


def run_ppo(
    seed: int = 100, episodes: int = 20, log_path: str | None = None, map: str = "hailu2001",
    **overrides: Any,
) -> dict[str, Any]:
    """Train PPO for ``episodes`` episodes; per-episode rows and the reliability summary.

    ``log_path``: a CSV that gets every episode as it ends (so a long run can be watched or
    cut short without losing what it learned so far).
    """
    import torch
    from torchrl.collectors import Collector
    from torchrl.data import LazyTensorStorage, ReplayBuffer
    from torchrl.data.replay_buffers.samplers import SamplerWithoutReplacement
    from torchrl.objectives import ClipPPOLoss
    from torchrl.objectives.value import GAE
    from tqdm.auto import tqdm

    cfg = PPOConfig(episodes=episodes, seed=seed, **overrides)
    if cfg.episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {cfg.episodes}")
    torch.manual_seed(seed)
    np.random.seed(seed)
    t0 = time.perf_counter()
    env = make_env(seed, map)
    actor, critic = make_modules(env, cfg.hidden)
    gae = GAE(gamma=cfg.gamma, lmbda=cfg.lmbda, value_network=critic, average_gae=True)
    loss = ClipPPOLoss(
        actor,
        critic,
        clip_epsilon=cfg.clip,
        entropy_bonus=cfg.entropy_coef > 0,
        entropy_coeff=cfg.entropy_coef,
        critic_coeff=cfg.critic_coef,
    )
    optim = torch.optim.Adam(loss.parameters(), lr=cfg.lr)
    buffer = ReplayBuffer(
        storage=LazyTensorStorage(cfg.frames_per_batch),
        sampler=SamplerWithoutReplacement(),
        batch_size=cfg.minibatch,
    )
    collector = Collector(
        env, actor, frames_per_batch=cfg.frames_per_batch, total_frames=-1,
        trust_policy=True,
    )
    rows: list[dict[str, Any]] = []
    logged = 0
    coll: dict[int, int] = {}
    frames = 0
    bar = tqdm(total=cfg.episodes, desc=f"ppo seed {seed}", unit="episode", mininterval=10)
    log = open(log_path, "w", newline="") if log_path else None  # noqa: SIM115 (closed below)
    log_writer = None
    for batch in collector:
        frames += batch.numel()
        traj = batch["collector", "traj_ids"].reshape(-1).numpy()
        hit = batch["next", "collision"].reshape(-1).numpy().astype(int)
        for t, c in zip(traj, hit, strict=True):
            coll[int(t)] = coll.get(int(t), 0) + int(c)
        done = batch["next", "done"].reshape(-1).numpy()
        for i in np.nonzero(done)[0]:
            rows.append(
                {
                    "seed": seed,
                    "episode": len(rows) + 1,
                    "steps": int(batch["next", "step_count"].reshape(-1)[i]),
                    "total_reinforcement": float(batch["next", "episode_reward"].reshape(-1)[i]),
                    "reached_goal": bool(batch["next", "terminated"].reshape(-1)[i]),
                    "collisions": coll.pop(int(traj[i]), 0),
                    "frames": frames,
                }
            )
        if log is not None and rows:
            if log_writer is None:
                log_writer = csv.DictWriter(log, fieldnames=list(rows[0]))
                log_writer.writeheader()
            log_writer.writerows(rows[logged:])
            log.flush()
        logged = len(rows)
        bar.n = min(len(rows), cfg.episodes)
        bar.set_postfix(success20=f"{np.mean([r['reached_goal'] for r in rows[-20:]]):.2f}")
        if len(rows) >= cfg.episodes:
            break
        with torch.no_grad():
            gae(batch)
        buffer.extend(batch.reshape(-1))
        for _ in range(cfg.epochs):
            for _ in range(cfg.frames_per_batch // cfg.minibatch):
                mb = buffer.sample()
                out = loss(mb)
                total = out["loss_objective"] + out["loss_critic"] + out.get("loss_entropy", 0.0)
                optim.zero_grad()
                total.backward()
                torch.nn.utils.clip_grad_norm_(loss.parameters(), cfg.max_grad_norm)
                optim.step()
        collector.update_policy_weights_()
    collector.shutdown()
    bar.close()
    if log is not None:
        log.close()
    rows = rows[: cfg.episodes]
    reached = [r["reached_goal"] for r in rows]
    return {
        "seed": seed,
        "map": map,
        "config": asdict(cfg),
        "rows": rows,
        "episodes": len(rows),
        "frames": frames,
        "successes": int(sum(reached)),
        "first_success": next((r["episode"] for r in rows if r["reached_goal"]), None),
        "first_reliable": first_reliable(reached, cfg.window, cfg.reliable),
        "success_last20": float(np.mean(reached[-20:])) if rows else 0.0,
        "steps_last20_mean": float(np.mean([r["steps"] for r in rows[-20:]])) if rows else None,
        "total_reinforcement_last20_mean": (
            float(np.mean([r["total_reinforcement"] for r in rows[-20:]])) if rows else None
        ),
        "wall_time_s": round(time.perf_counter() - t0, 1),
    }


def summary_markdown(results: list[dict[str, Any]]) -> str:
    """One row per seed."""
    lines = [
        "| seed | episodes | env steps | successes | first success | first reliable (>=80% of 20) "
        "| success last 20 | steps last 20 | total reinf. last 20 | wall time (s) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in results:
        lines.append(
            f"| {r['seed']} | {r['episodes']} | {r['frames']} | {r['successes']} "
            f"| {r['first_success'] or 'never'} | {r['first_reliable'] or 'never'} "
            f"| {r['success_last20']:.0%} | {r['steps_last20_mean']:.1f} "
            f"| {r['total_reinforcement_last20_mean']:.2f} | {r['wall_time_s']} |"
        )
    return "\n".join(lines) + "\n"


def baseline_command(args: argparse.Namespace) -> int:
    """`symrl baseline ppo`: one PPO run per seed (in parallel); write and print the summary."""
    from symrl.studies.runner import run_jobs

    try:
        seeds = [int(s) for s in str(args.seeds).split(",") if s.strip()]
    except ValueError:
        raise ValueError(f"--seeds {args.seeds!r}: expected comma-separated integers") from None
    if not seeds:
        raise ValueError("--seeds: give at least one seed")
    t0 = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [
        {"seed": s, "episodes": args.episodes, "log_path": str(out / f"episodes-seed{s}.csv"),
         "map": args.map}
        for s in seeds
    ]
    results = run_jobs(run_ppo, jobs, workers=None, desc="ppo")
    with open(out / "episodes.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(results[0]["rows"][0]))
        writer.writeheader()
        for res in results:
            writer.writerows(res["rows"])
    summary = [{k: v for k, v in r.items() if k != "rows"} for r in results]
    wall = round(time.perf_counter() - t0, 1)
    (out / "summary.json").write_text(json.dumps({"runs": summary, "wall_time_s": wall}, indent=2))
    md = summary_markdown(results)
    (out / "summary.md").write_text(md)
    from symrl.figures import plot_baseline

    plot_baseline(results, out / "ppo.png",
                  f"PPO (TorchRL) on symrl/Hailu2001-v0, map {args.map}")
    print(md)
    print(f"wrote {out}/ (episodes.csv, summary.json, summary.md, ppo.png); wall time {wall} s")
    return 0
