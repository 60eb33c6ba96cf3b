"""Evidence for docs/LEARNING.md: the paper recipe, each of its switches removed, and the baselines.

Runs the real learner (``symrl.train.train``: TorchRL Collector, policy, TeseoLoss) for every
variant on the report seeds and caches one JSON per variant, then draws the figures and prints
the ablation table. Re-running skips variants already cached (``--force`` recomputes).

    python benchmarks/learning_report.py run --seeds 100-109              # all variants (~15 min)
    python benchmarks/learning_report.py run --seeds 100-109 --only paper paper_literal
    python benchmarks/learning_report.py report --seeds 100-109           # table + figures

Outputs: ``docs/figures/learning/<variant>.json`` (per-trial records without paths, plus the
last trial's path), ``docs/figures/learning_curves.png``, ``docs/figures/final_paths.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "figures"
CACHE = OUT / "learning"  # one JSON per variant (``--cache`` for another seed group)

_FLFR_SECTION4 = ["reflex.near.FL=[0.2, 0.5]", "reflex.near.FR=[0.2, 0.5]"]
_FLFR_SOFT = ["reflex.near.FL=[0.1, 0.35]", "reflex.near.FR=[0.1, 0.35]"]

# name -> (recipe, overrides). "paper - X" removes one switch of the paper recipe.
VARIANTS: dict[str, tuple[str, list[str]]] = {
    "paper": ("paper", []),
    "paper - options": ("paper", ["learner.options=false"]),
    "paper - residual": ("paper", ["learner.residual=false"]),
    "paper - low temperature": (
        "paper",
        ["learner.temperature0=0.3", "learner.temperature_min=0.05"],
    ),
    "paper - subgoal_past": ("paper", ["learner.subgoal_past=false"]),
    "paper - safe sub-goals": (
        "paper",
        ["learner.subgoal_on_line=true", "learner.subgoal_min_clearance=0.0"],
    ),
    "paper - averaging critic": ("paper", ["learner.option_critic=best"]),
    "paper - try untried first": ("paper", ["learner.option_try_untried=false"]),
    "paper - greedy_after": ("paper", ["learner.option_greedy_after=0"]),
    "paper - shield": ("paper", ["learner.shield=false"]),
    "paper - soft FL/FR (0.2-0.5 m as section 4)": ("paper", [*_FLFR_SECTION4]),
    "paper - soft reflex (d_a 0.7 and FL/FR as section 4)": (
        "paper",
        ["reflex.d_a=0.7", *_FLFR_SECTION4],
    ),
    "paper - RBF experts (learning off)": ("paper", ["learner.learning=false"]),
    "paper + learned avoidance [0.7, 0.5, 0.3]": (
        "paper",
        ["learner.option_avoidance=[0.7, 0.5, 0.3]"],
    ),
    "paper_literal": ("paper_literal", []),
    "reflex_only": ("reflex_only", []),
    "reflex_only + shield + soft reflex": (
        "reflex_only",
        ["learner.shield=true", "reflex.d_a=0.5", *_FLFR_SOFT],
    ),
    "no_partition": ("no_partition", []),
    "no_reflex": ("no_reflex", []),
    "plain": ("plain", []),
}


_COLUMNS = (
    "trial", "steps", "total_reinforcement", "collisions", "shielded", "reached_goal", "neurons",
)  # fmt: skip


def _keep(key: str) -> bool:
    """The per-trial columns worth keeping (the option choices too); paths are stored apart."""
    return key in _COLUMNS or key.startswith(("option_", "avoid_", "neurons_"))


def _slug(name: str) -> str:
    """A file name for a variant: "paper - shield" -> "paper__minus__shield"."""
    text = name.replace(" - ", "__minus__").replace(" + ", "__plus__")
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b) + 1)) if b else [int(s) for s in text.split(",")]


def run_variant(name: str, seeds: list[int], trials: int) -> dict:
    """Train one variant on every seed; keep scalar columns and the last trial's path."""
    from symrl.learner.config import load_config
    from symrl.train import train

    recipe, overrides = VARIANTS[name]
    sets = []
    started = time.perf_counter()
    for seed in seeds:
        config = load_config(recipe, [f"run.seed={seed}", f"run.trials={trials}", *overrides])
        result = train(config, progress=False)
        rows = [{k: v for k, v in t.items() if _keep(k)} for t in result.trials]
        sets.append(
            {
                "seed": seed,
                "trials": json.loads(json.dumps(rows, default=float)),
                "last_path": [list(map(float, p)) for p in result.trials[-1]["path"]],
            }
        )
    return {
        "variant": name,
        "recipe": recipe,
        "overrides": overrides,
        "seeds": seeds,
        "seconds": time.perf_counter() - started,
        "sets": sets,
    }


def summary(data: dict, last: int = 5) -> dict[str, float]:
    """Last-``last`` means over sets; the latest first trial from which all later ones reached."""

    def col(key: str) -> np.ndarray:
        return np.array([[float(t.get(key, 0.0)) for t in s["trials"]] for s in data["sets"]])

    total, steps, coll = col("total_reinforcement"), col("steps"), col("collisions")
    reached = col("reached_goal") > 0.5
    firsts = []
    for row in reached:
        idx = [i for i in range(len(row)) if row[i:].all()]
        firsts.append(idx[0] + 1 if idx else math.inf)
    first_reach = [int(np.argmax(row)) + 1 if row.any() else math.inf for row in reached]
    return {
        "total": float(total[:, -last:].mean()),
        "total_sd_sets": float(total[:, -last:].mean(axis=1).std()),
        "steps": float(steps[:, -last:].mean()),
        "collisions": float(coll[:, -last:].mean()),
        "collisions_all": float(coll.mean()),
        "shielded": float(col("shielded")[:, -last:].mean()),
        "neurons": float(col("neurons")[:, -1].mean()),
        "first_reach": float(np.mean(first_reach)),
        "all_reach_from": float(max(firsts)),
        "reached_last5": float(reached[:, -last:].mean()),
    }


def table(seeds_text: str) -> str:
    lines = [
        "| variant | last-5 total reinforcement | last-5 actions | last-5 collisions / trial "
        "| collisions / trial, all 20 | shield vetoes / trial, last 5 | neurons (trial 20) "
        "| first trial reaching the goal (mean) | all trials reach from |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name in VARIANTS:
        path = CACHE / f"{_slug(name)}.json"
        if not path.exists():
            continue
        s = summary(json.loads(path.read_text()))
        steps = f"{s['steps']:.1f}" if s["reached_last5"] > 0 else "never reaches"
        first = "never" if math.isinf(s["first_reach"]) else f"{s['first_reach']:.1f}"
        all_from = "never" if math.isinf(s["all_reach_from"]) else f"{s['all_reach_from']:.0f}"
        lines.append(
            f"| {name} | {s['total']:.2f} (±{s['total_sd_sets']:.2f}) | {steps} | "
            f"{s['collisions']:.2f} | {s['collisions_all']:.2f} | {s['shielded']:.2f} | "
            f"{s['neurons']:.0f} | {first} | {all_from} |"
        )
    return f"seeds {seeds_text}, 20 trials, noise on; ± = sd of the set means\n\n" + "\n".join(
        lines
    )


def figures() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from symrl.studies.figures import draw_map  # shared map drawing
    from symrl.world.worldmap import load_map

    curves = ["paper", "paper_literal", "reflex_only"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name in curves:
        path = CACHE / f"{_slug(name)}.json"
        if not path.exists():
            continue
        data = json.loads(path.read_text())
        for ax, key in zip(axes, ("total_reinforcement", "steps"), strict=True):
            arr = np.array([[float(t[key]) for t in s["trials"]] for s in data["sets"]])
            x = np.arange(1, arr.shape[1] + 1)
            (line,) = ax.plot(x, arr.mean(axis=0), marker="o", ms=3, label=name)
            ax.fill_between(x, arr.min(axis=0), arr.max(axis=0), alpha=0.15, color=line.get_color())
    axes[0].set(
        xlabel="trial", ylabel="total reinforcement", title="mean over sets (band: min-max)"
    )
    axes[1].set(
        xlabel="trial", ylabel="actions to the goal", title="mean over sets (band: min-max)"
    )
    axes[0].axhline(-11, ls="--", c="grey", lw=0.8)
    axes[0].axhline(-8, ls=":", c="grey", lw=0.8)
    axes[1].axhline(30, ls="--", c="grey", lw=0.8)
    axes[1].axhline(28, ls=":", c="grey", lw=0.8)
    axes[0].set_ylim(-40, 0)
    axes[1].set_ylim(20, 60)
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(OUT / "learning_curves.png", dpi=120)
    plt.close(fig)

    world = load_map("hailu2001")
    fig, axes = plt.subplots(1, 3, figsize=(14, 5))
    for ax, name in zip(axes, curves, strict=True):
        path = CACHE / f"{_slug(name)}.json"
        draw_map(ax, world)
        if path.exists():
            for s in json.loads(path.read_text())["sets"]:
                xy = np.array(s["last_path"])
                ax.plot(xy[:, 0], xy[:, 1], lw=1, alpha=0.7)
        ax.set_title(f"{name}: trial 20 of every set")
    fig.tight_layout()
    fig.savefig(OUT / "final_paths.png", dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["run", "report"])
    parser.add_argument("--seeds", default="100-109")
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--only", nargs="*", default=None, help="variant names (default: all)")
    parser.add_argument("--force", action="store_true")
    parser.add_argument(
        "--cache",
        default=None,
        help="folder of the per-variant JSON (default docs/figures/learning)",
    )
    parser.add_argument("--no-figures", action="store_true", help="report: the table only")
    args = parser.parse_args()
    global CACHE
    if args.cache:
        CACHE = Path(args.cache)
    CACHE.mkdir(parents=True, exist_ok=True)
    if args.command == "run":
        for name in args.only or list(VARIANTS):
            path = CACHE / f"{_slug(name)}.json"
            if path.exists() and not args.force:
                continue
            data = run_variant(name, _seeds(args.seeds), args.trials)
            path.write_text(json.dumps(data))
            s = summary(data)
            print(
                f"{name}: total {s['total']:.2f} actions {s['steps']:.1f} "
                f"collisions {s['collisions']:.2f} neurons {s['neurons']:.0f} "
                f"[{data['seconds']:.0f}s]",
                flush=True,
            )
    else:
        if not args.no_figures:
            figures()
        print(table(args.seeds))


if __name__ == "__main__":
    main()
