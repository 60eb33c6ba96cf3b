"""How far the odometry drifts along a trial, and how far the map localisation's pose (or, with
``--tracker scan``, the scan odometry's) is from the true one (a script, not a test: the numbers
behind docs/journal/learning.md, "Map localisation", and docs/journal/scan-odometry.md).

For each map, ``drives`` robots (noise seeds ``seed`` ...) start at the map's start, and the
shielded reflex drives them toward the goal by their odometry, as ``reflex_only`` does. At every
step the localiser (``symrl.knowledge.localize.PoseTracker``, the settings of ``paper``) turns
the odometry pose and the sonar scan into a believed pose, which is only recorded: the reflex
keeps steering by the odometry, so the drift is the one the learner would face without it.
Prints the position error of the odometry and of the belief over all steps and at each
trial's end; ``--figure PATH`` draws one robot's true, odometry and believed paths per map.
With ``--tracker scan`` the belief is the scan odometry's (``symrl.knowledge.scan_odometry``,
the settings of ``paper``), which reads no map, and the table gives both errors after 20, 40, 60
and 80 actions.

    python docs/journal/scripts/localisation_drift.py [--maps hailu2001,l_corridor,maze]
        [--drives 30] [--tracker map|scan]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from symrl.knowledge.localize import MapLocalizer, PoseTracker
from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.scan_odometry import ScanOdometry
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.learner.config import load_config
from symrl.world import load_map
from symrl.world.physics import RobotBatch


def drift(name: str, drives: int, seed: int, scan: bool = False) -> dict[str, np.ndarray]:
    """True, odometry and believed poses (T + 1, B, 3) and the steps each robot was driving
    (``scan``: the belief the scan odometry's, else the map localisation's)."""
    config = load_config("paper" if scan else "paper_map", [f"env.map={name}"])
    world, robot = load_map(name), config.env.robot
    physics = RobotBatch(world, robot, drives, noise=True, max_actions=config.env.max_actions)
    rngs = [np.random.default_rng(seed + b) for b in range(drives)]
    start = np.tile([world.start.x, world.start.y, world.start.heading], (drives, 1))
    r = physics.reset(np.arange(drives), start, rngs)
    lc, so = config.localize, config.scan_odometry
    tracker = (
        ScanOdometry(robot, drives, so.keyframe_actions, so.iterations)
        if scan
        else PoseTracker(
            MapLocalizer(
                physics.walls,
                robot,
                lc.iterations,
                lc.prior_xy,
                lc.prior_heading,
                max_move=lc.max_move,
            ),
            drives,
        )
    )
    reflex, shield = FuzzyReflex(config.reflex), IRShield(ShieldConfig(), robot)
    true, odometry, belief, alive = [], [], [], []
    driving = np.ones(drives, dtype=bool)
    with torch.no_grad():
        while driving.any():
            true.append(r.true_pose.copy())
            odometry.append(r.odometry.astype(np.float64))
            belief.append(tracker(r.odometry, r.sonar))
            alive.append(driving.copy())
            sonar = torch.from_numpy(r.sonar.astype(np.float64))
            action = reflex(sonar, torch.from_numpy(r.goal[:, 1].astype(np.float64)))
            action, _ = shield(torch.from_numpy(r.ir), action)
            r = physics.step(action.numpy().astype(np.float32), rngs)
            driving &= ~(r.reached_goal | r.truncated)
    runs = {"true": true, "odometry": odometry, "belief": belief, "alive": alive}
    return {key: np.stack(value) for key, value in runs.items()}


def summary(name: str, d: dict[str, np.ndarray]) -> str:
    alive = d["alive"]
    last = alive.sum(0) - 1  # each robot's last recorded step

    def err(key: str) -> tuple[np.ndarray, np.ndarray]:
        e = np.hypot(*(d[key][..., :2] - d["true"][..., :2]).transpose(2, 0, 1))
        return e[alive], e[last, np.arange(e.shape[1])]

    (_, odo_end), (bel, bel_end) = err("odometry"), err("belief")
    return (
        f"| `{name}` | {alive.sum(0).mean():.1f} | {odo_end.mean():.3f} | {odo_end.max():.3f} "
        f"| {bel.mean() * 1000:.1f} | {np.quantile(bel, 0.99) * 1000:.1f} "
        f"| {bel.max() * 1000:.1f} | {bel_end.mean() * 1000:.1f} |"
    )


def growth(name: str, d: dict[str, np.ndarray], at: tuple[int, ...] = (20, 40, 60, 80)) -> str:
    """The odometry's and the belief's mean position error (m) after each of ``at`` actions,
    over the drives still driving then."""
    cells = []
    for key in ("odometry", "belief"):
        e = np.hypot(*(d[key][..., :2] - d["true"][..., :2]).transpose(2, 0, 1))
        for n in at:
            live = d["alive"][n] if n < len(e) else np.zeros(e.shape[1], dtype=bool)
            cells.append(f"{e[n][live].mean():.3f}" if live.any() else "-")
    return f"| `{name}` | {d['alive'].sum(0).mean():.1f} | " + " | ".join(cells) + " |"


def figure(
    runs: dict[str, dict[str, np.ndarray]], path: str, belief: str = "map localisation"
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from symrl.world.render import draw_world

    fig, axes = plt.subplots(1, len(runs), figsize=(5.0 * len(runs), 4.8), squeeze=False)
    for ax, (name, d) in zip(axes[0], runs.items(), strict=True):
        draw_world(ax, load_map(name), regions=False)
        ends = d["alive"].sum(0)
        last = d["true"][ends - 1, np.arange(len(ends))]
        drift = np.hypot(*(d["odometry"][ends - 1, np.arange(len(ends)), :2] - last[:, :2]).T)
        # the drive with the most drift at its end, among those that reached the goal if any
        arrived = ends < len(d["alive"])
        b = int(np.argmax(np.where(arrived, drift, -1.0) if arrived.any() else drift))
        n = int(ends[b])
        for key, color, label in (
            ("true", "black", "true path"),
            ("odometry", "tab:red", "odometry"),
            ("belief", "tab:blue", belief),
        ):
            xy = d[key][:n, b, :2]
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                color=color,
                lw=1.2,
                label=label,
                ls="--" if key == "belief" else "-",
            )
        ax.plot(*d["true"][0, b, :2], "o", mfc="white", mec="black", label="start")
        ax.set_title(f"{name}: {n} actions, odometry {drift[b]:.2f} m off at the end", fontsize=9)
        ax.set_aspect("equal")
        ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="hailu2001,l_corridor,maze")
    ap.add_argument("--drives", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--figure", default=None, metavar="PATH")
    ap.add_argument("--tracker", choices=("map", "scan"), default="map")
    args = ap.parse_args()
    torch.set_num_threads(1)
    scan = args.tracker == "scan"
    runs = {name: drift(name, args.drives, args.seed, scan) for name in args.maps.split(",")}
    print(
        f"{args.drives} drives per map of the shielded reflex, noise seeds {args.seed}-"
        f"{args.seed + args.drives - 1}; position errors against the true pose"
    )
    if scan:
        header = (
            "| world | actions | odometry after 20 | 40 | 60 | 80 "
            "| scan odometry after 20 | 40 | 60 | 80 |\n"
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        )
        row, label = growth, "scan odometry"
    else:
        header = (
            "| world | actions | odometry at the end, mean (m) | max (m) "
            "| belief, every step: mean (mm) | 99 % (mm) | max (mm) | belief at the end (mm) |\n"
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        )
        row, label = summary, "map localisation"
    print(header)
    for name, d in runs.items():
        print(row(name, d))
    if args.figure:
        figure(runs, args.figure, label)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
