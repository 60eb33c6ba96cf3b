"""TESEO (Hailu 2001) in one file: the learner of ``symrl train paper_literal``, top to bottom.

A reference to read, CleanRL-style: every step of the learner is written out here in plain
numpy and torch, in the order it runs, with the hyperparameters of ``recipes/paper_literal.yaml``
("every rule exactly as the paper states it"; ``docs/ALGORITHM.md``):

    seeding -> env (the Gymnasium env ``symrl/Hailu2001-v0``) -> region gate -> fuzzy reflex
    -> growing RBF experts -> the update (TD error, growth, REINFORCE, temperature)
    -> logging (one line per trial and a trials.csv)

What ``paper_literal`` turns on is all there is here: one expert per region (the partition
gate), new neurons that start from the reflex's action, absolute actions (no residual), and
the reflex always steering at the goal. What it leaves off is left out: sub-goal options and
their critic, border crossings, the IR shield, map localisation, the trial gradient.

Only two parts come from the library: the fuzzy reflex (``symrl.knowledge.reflex``) and the
region rules (``symrl.knowledge.regions``), which are what the robot is told, not what it
learns. The library's learner (``symrl/learner``, ``symrl/train.py``) runs a batch of robots
through TorchRL; this file runs one robot on the Gymnasium env. They are the same computation:
``tests/test_single_file_example.py`` runs both on one seed and requires the two trials.csv
files to be byte-identical, so every rounding and every random draw here is the library's.

    python examples/teseo_paper.py --seed 0 --trials 20 --out trials.csv
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import gymnasium
import numpy as np
import torch

import symrl  # registers the Gymnasium env symrl/Hailu2001-v0
from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.regions import RegionMapper

# -- hyperparameters (recipes/paper_literal.yaml) ------------------------------------------------
MAX_ACTIONS = 200  # a trial fails after this many actions
WIDTH_CODES, GOAL_CODES = 1.0, 8  # goal-distance codes phi_m (Eq. 2)
NOVELTY_RADIUS = 0.1  # a state farther than this from every neuron grows one (paper 8.1)
GAMMA, ETA, BETA, KAPPA = 0.95, 0.3, 0.2, 0.1  # discount, TD rate, REINFORCE rate, centre shift
ERROR_THRESHOLD = 2.0  # |delta| above this grows a neuron instead of learning (paper 8.3)
T0, COOLING, T_MIN = 0.3, 0.85, 0.05  # exploration temperature, cooled after each trial
UTILITY_CAP = 60.0  # exp(u) is taken of min(u, 60)
BLOCK = 1024  # the exploration noise is drawn in blocks of this many normals, then uniforms
PI = math.pi


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument(
        "--max-actions",
        type=int,
        default=MAX_ACTIONS,
        help="actions before a trial fails (the CLI's env.max_actions=N)",
    )
    parser.add_argument("--out", type=Path, default=Path("trials.csv"), help="the trial table")
    return parser.parse_args()


# -- perception: what the robot makes of an observation --------------------------------------------
class Perception:
    """The region gate (the paper's symbolic rules on the odometry pose) and the experts' input
    x = (24 normalised sonars, 8 goal-distance codes) (paper 6.1, Eq. 2)."""

    def __init__(self, world) -> None:
        self.regions = RegionMapper(world.regions)  # the rules: first one that holds wins
        self.names = tuple(self.regions.names)
        start, goal = world.start, world.goal
        self.start_distance = max(math.hypot(start.x - goal.x, start.y - goal.y), 1e-9)
        self.centres = torch.arange(GOAL_CODES, dtype=torch.float32) / (GOAL_CODES - 1)

    def __call__(self, obs: dict) -> tuple[int, np.ndarray]:
        """(region, x) of one observation; the region picks the expert (one per region)."""
        xy = obs["odometry"][None, :2].astype(np.float64)
        region = int(self.regions.ids_np(xy)[0])
        # rho = goal distance over the start's, in [0, 1]; phi_m = exp(-((mu_m - rho) / w)^2)
        rho = (torch.from_numpy(obs["goal"][None, 0]) / self.start_distance).clamp(0.0, 1.0)
        codes = torch.exp(-(((self.centres - rho[:, None]) / WIDTH_CODES) ** 2))
        x = torch.cat((torch.from_numpy(obs["sonar"][None]), codes), dim=-1)
        return region, x.numpy()[0]


def reset_reinforcement(obs: dict, info: dict, world, robot) -> np.float32:
    """r(s) of a trial's first state (Eqs. 3, 4 without a collision), which the Gymnasium env
    reports as 0: a neuron born there starts with this utility. f2 from the heading against the
    goal's direction; f1 from the nearest sonar, here the observation's (float32) where the
    physics has its float64 reading: the same f1 unless the start is within d_c = 0.3 m of a
    wall (the paper's start is 1.2 m from the nearest)."""
    dmin = float(obs["sonar"].min()) * robot.sonar_range
    close = robot.close_distance
    f1 = -1.0 + dmin / close if dmin < close else 0.0
    x, y, h = (float(v) for v in info["true_pose"])  # the odometry is the true pose here
    angle = math.atan2(world.goal.y - y, world.goal.x - x)
    f2 = -abs(float(np.mod(h - angle + PI, 2 * PI) - PI)) / PI
    return np.float32(f1 + f2)


# -- the experts: one growing RBF network per region ---------------------------------------------
class Expert:
    """Neurons j with a centre c_j (an input), a prototypical action p_j, a utility u_j and an
    exploration mean mu_j (paper 7.1); the nearest neuron to the input wins."""

    def __init__(self, dim: int) -> None:
        self.centres = np.zeros((0, dim), dtype=np.float32)
        self.actions = np.zeros(0)  # p_j
        self.utilities = np.zeros(0)  # u_j
        self.means = np.zeros(0)  # mu_j
        self.taken = np.zeros(0)  # the action neuron j took last in this trial
        self.used = np.zeros(0, dtype=bool)  # whether it acted in this trial

    def __len__(self) -> int:
        return len(self.actions)

    def nearest(self, x: np.ndarray) -> tuple[int, np.float32 | float]:
        """Winner (-1 if empty) and its distance (inf if empty), float32 as the library's."""
        if len(self) == 0:
            return -1, math.inf
        squares = np.square(self.centres[None] - x[None, None])
        d2 = torch.from_numpy(squares).sum(-1).numpy()[0]  # torch's float32 reduction
        winner = int(d2.argmin())
        return winner, np.sqrt(d2[winner])

    def add(self, centre: np.ndarray, action: float, utility: float) -> int:
        """Grow one neuron; returns its index."""
        self.centres = np.concatenate((self.centres, centre[None]))
        self.actions = np.append(self.actions, action)
        self.utilities = np.append(self.utilities, utility)
        self.means = np.append(self.means, 0.0)
        self.taken = np.append(self.taken, 0.0)
        self.used = np.append(self.used, False)
        return len(self) - 1


def is_novel(distance: np.float32 | float) -> bool:
    """No neuron within the novelty radius (compared in float32, as numpy compares a float32
    array with a Python float)."""
    return bool(np.asarray([distance]) > NOVELTY_RADIUS)


# -- exploration noise: the library's stream, one normal per action ------------------------------
class Noise:
    """Standard normals from a torch generator seeded with the run's seed, drawn in blocks of
    1024 normals then 1024 uniforms (the uniforms give a new neuron's action when there is no
    reflex; here they are drawn and left unused, so the stream is the library's)."""

    def __init__(self, seed: int) -> None:
        self.generator = torch.Generator().manual_seed(seed)
        self.normals, self.drawn = np.zeros(0), 0

    def __call__(self) -> float:
        if self.drawn >= len(self.normals):
            self.normals = torch.randn(BLOCK, generator=self.generator, dtype=torch.float64).numpy()
            torch.rand(BLOCK, generator=self.generator, dtype=torch.float64)
            self.drawn = 0
        self.drawn += 1
        return float(self.normals[self.drawn - 1])


def main() -> None:
    args = parse_args()

    # -- seeding and the env ------------------------------------------------------------------
    env = gymnasium.make(symrl.ENV_ID, map="hailu2001", noise=True, max_actions=args.max_actions)
    world, robot = env.unwrapped.world, env.unwrapped.robot
    noise = Noise(args.seed)  # the learner's stream; the world's is the env's own
    obs, info = env.reset(seed=args.seed)  # later resets go on with the same stream

    perceive = Perception(world)
    reflex = FuzzyReflex()  # obstacle avoidance and goal following (paper 5)
    experts = [Expert(robot.n_sensors + GOAL_CODES) for _ in perceive.names]
    temperature, best_total = T0, -math.inf

    columns = [
        "trial",
        "steps",
        "total_reinforcement",
        "collisions",
        "shielded",
        "reached_goal",
        "neurons",
        "temperature",
        "replaced",
        "improved",
        "mean_abs_td_error",
        "path_length",
        *(f"neurons_{n}" for n in perceive.names),
    ]
    out = open(args.out, "w", newline="")  # noqa: SIM115 - closed at the end
    table = csv.DictWriter(out, fieldnames=columns)
    table.writeheader()

    for trial in range(1, args.trials + 1):
        if trial > 1:
            obs, info = env.reset()
        region, x = perceive(obs)
        state_reward = reset_reinforcement(obs, info, world, robot)
        path = [info["true_pose"][:2]]
        steps, total, collisions, td_sum = 0, 0.0, 0, 0.0
        reached = False
        while True:
            # -- act: the region's expert, its nearest neuron, Gullapalli's Gaussian unit (Eq. 6)
            expert = experts[region]
            winner, distance = expert.nearest(x)
            novel = is_novel(distance)
            z = noise()
            # the reflex's action (what a neuron born here takes: paper 8.3)
            sonar = torch.from_numpy(obs["sonar"][None].astype(np.float64))
            goal_angle = torch.tensor([float(obs["goal"][1])], dtype=torch.float64)
            proto = float(reflex(sonar, goal_angle)[0])
            if novel:  # act as the neuron the update grows here will: p = reflex, u = r(s)
                p, mu, u = proto, 0.0, float(state_reward)
            else:
                p, mu, u = expert.actions[winner], expert.means[winner], expert.utilities[winner]
            # sigma = T / (1 + e^u): confident (high-utility) neurons explore less
            e = float(torch.tensor([min(u, UTILITY_CAP)], dtype=torch.float64).exp()[0])
            sigma = temperature / (1.0 + e)
            xi = mu + sigma * z
            alpha = min(max(p + xi, -PI), PI)

            obs, reward, terminated, truncated, info = env.step(np.array([alpha], np.float32))
            r32 = np.float32(reward)
            r = float(r32)
            next_region, next_x = perceive(obs)

            # -- the update (paper 8.3): first the neuron the robot acted as at a novel state
            if novel:
                winner = expert.add(x, proto, float(state_reward))
            expert.taken[winner], expert.used[winner] = alpha, True  # for action replacement
            u_prev = expert.utilities[winner]
            # u' of the state reached: 0 at the goal; r if it is novel (a new neuron's utility);
            # else its winner's (a trial cut at the budget bootstraps from the nearest neuron)
            seen = experts[next_region]
            seen_winner, seen_distance = seen.nearest(next_x)
            u_seen = seen.utilities[seen_winner] if seen_winner >= 0 else 0.0
            if terminated:
                u_next = 0.0
            elif truncated:
                u_next = u_seen if seen_winner >= 0 else u_prev
            else:
                u_next = r if is_novel(seen_distance) else u_seen
            delta = r + GAMMA * u_next - u_prev  # the TD error
            split = abs(delta) > ERROR_THRESHOLD
            if split:  # error-driven growth: a new neuron at x, the winner left as it was
                expert.add(x, proto, u_prev + delta)
            step = 0.0 if split else delta
            expert.utilities[winner] = u_prev + ETA * step  # TD(0)
            mu = expert.means[winner]
            expert.means[winner] = mu + BETA * step * (xi - mu)  # REINFORCE
            if not split and delta > 0:  # the centre moves toward the input: c += kappa (x - c)
                moved = torch.from_numpy(expert.centres[winner][None].copy())
                moved.lerp_(torch.from_numpy(x[None]), KAPPA)
                expert.centres[winner] = moved.numpy()[0]

            # -- bookkeeping of the trial
            steps += 1
            total += r
            collisions += int(info["collision"])
            td_sum += abs(delta)
            path.append(info["true_pose"][:2])
            if terminated or truncated:
                reached = bool(terminated)
                break
            region, x, state_reward = next_region, next_x, r32

        # -- end of trial: action replacement after a better success, then cooling (paper 8.3)
        total32 = float(np.float32(total))
        improved = reached and total32 > best_total
        replaced = 0
        if improved:
            best_total = total32
            for ex in experts:  # p <- the action taken, mu <- 0, for every neuron used
                ex.actions = np.where(ex.used, ex.taken, ex.actions)
                ex.means = np.where(ex.used, 0.0, ex.means)
                replaced += int(ex.used.sum())
        explored, temperature = temperature, max(COOLING * temperature, T_MIN)
        for ex in experts:
            ex.used[:] = False

        # -- logging
        xy = np.array(path)
        row = {
            "trial": trial,
            "steps": steps,
            "total_reinforcement": total,
            "collisions": collisions,
            "shielded": 0,
            "reached_goal": reached,
            "neurons": sum(len(ex) for ex in experts),
            "temperature": explored,
            "replaced": replaced,
            "improved": improved,
            "mean_abs_td_error": td_sum / steps,
            "path_length": float(np.sqrt(np.add.reduce(np.square(xy[1:] - xy[:-1]), 1)).sum()),
            **{f"neurons_{n}": len(ex) for n, ex in zip(perceive.names, experts, strict=True)},
        }
        table.writerow({k: f"{v:.6g}" if isinstance(v, float) else v for k, v in row.items()})
        out.flush()
        print(
            f"trial {trial:3d}: {steps:3d} actions, total {total:7.2f}, "
            f"{'goal' if reached else 'no goal'}, {row['neurons']} neurons, T {explored:.3f}"
        )
    out.close()
    env.close()


if __name__ == "__main__":
    main()
