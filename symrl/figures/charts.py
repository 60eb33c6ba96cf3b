"""The figures of numbers over trials and recipes: learning curves, recipe and map
comparisons, the baselines' curves, and the knowledge ladder per world."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np

if TYPE_CHECKING:
    pass

from matplotlib.ticker import MaxNLocator

from symrl.figures.parts import MARKERS, STYLES, fixed_margins


def plot_ladder_worlds(
    entries: Sequence[Mapping[str, Any]], path: Path | str, top: float = 2.5
) -> None:
    """Grouped bars: per world, each recipe's actions over the last trials divided by the
    world's optimum (mean over sets, sd as the error bar); 1 is the optimum. Bars above ``top``
    are cut there and labelled with their value; a number over a bar counts its failed trials
    (from trial 5 on)."""
    worlds = list(dict.fromkeys(e["world"] for e in entries))
    recipes = list(dict.fromkeys(e["recipe"] for e in entries))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(worlds) + 2.5), 4.2))
    width = 0.8 / max(len(recipes), 1)
    labelled: set[str] = set()
    for e in entries:
        i, j = recipes.index(e["recipe"]), worlds.index(e["world"])
        x = j + (i - (len(recipes) - 1) / 2) * width
        ratio = min(e["ratio"], top)
        ax.bar(
            x, ratio, width, color=f"C{i}", label=None if e["recipe"] in labelled else e["recipe"]
        )
        labelled.add(e["recipe"])
        cut = e["ratio"] > top
        if cut:
            ax.text(x, top, f"{e['ratio']:.1f}", ha="center", va="bottom", fontsize=7)
        else:
            ax.errorbar(x, ratio, yerr=e["ratio_sd"], color="black", lw=0.8, capsize=2)
        if e.get("failed_from"):
            ax.text(
                x,
                top * 0.97 if cut else ratio + e["ratio_sd"] + 0.03,
                f"✗{e['failed_from']}",
                ha="center",
                va="top" if cut else "bottom",
                fontsize=6,
                color="white" if cut else "tab:red",
                rotation=90,
            )
    ax.axhline(1.0, color="black", lw=0.8, ls="--", label="optimum (planner)")
    slanted = len(worlds) > 4
    ax.set_xticks(
        range(len(worlds)),
        worlds,
        rotation=20 if slanted else 0,
        ha="right" if slanted else "center",
    )
    ax.set_ylabel("actions, last 5 trials / optimum")
    ax.set_ylim(0, top * 1.12)
    ax.set_title("The knowledge ladder per world (mean over sets ± sd; ✗ failed trials from 5)")
    ax.legend(fontsize=8, ncol=2, loc="upper left")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_curves(
    curves: dict[str, np.ndarray],
    path: Path | str,
    reference: dict[str, float] | None = None,
    title: str = "",
) -> None:
    """Learning curves (one panel per quantity): mean over sets with min-max bars (Figs 7-9).

    ``curves[name]`` is (sets, trials); ``reference[name]`` draws a dashed line (paper / optimum).
    """
    names = list(curves)
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.4), squeeze=False)
    for ax, name in zip(axes[0], names, strict=False):
        v = np.asarray(curves[name], dtype=float)
        trials = np.arange(1, v.shape[1] + 1)
        mean = np.nanmean(v, axis=0)
        lo, hi = np.nanmin(v, axis=0), np.nanmax(v, axis=0)
        ax.errorbar(trials, mean, yerr=[mean - lo, hi - mean], fmt="o-", ms=3, capsize=2)
        refs = [(k, v) for k, v in (reference or {}).items() if k.startswith(name + ":")]
        for i, (label, value) in enumerate(refs):  # labels alternate ends so they never overlap
            ax.axhline(value, ls="--", lw=1, color="0.4")
            ax.annotate(
                label.split(":", 1)[1],
                (trials[-1] if i % 2 == 0 else trials[0], value),
                fontsize=7,
                ha="right" if i % 2 == 0 else "left",
                va="bottom",
                color="0.3",
            )
        ax.set_xlabel("trial")
        ax.set_ylabel(name.replace("_", " "))
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if title:
        fig.suptitle(title)
    fixed_margins(
        fig, 1, len(names), left=0.75, bottom=0.55, top=0.55 if title else 0.3, gap_x=0.85
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _comparison_row(
    axes: Sequence[Any], curves: dict[str, dict[str, np.ndarray]], quantities: Sequence[str]
) -> None:
    """Per quantity (one axis each), each recipe's mean over sets (shaded min-max)."""
    n_recipes = len(curves)
    for ax, q in zip(axes, quantities, strict=False):
        for i, (recipe, per_q) in enumerate(curves.items()):
            v = np.asarray(per_q[q], dtype=float)
            # a small offset per recipe: recipes whose curves coincide stay visible
            trials = np.arange(1, v.shape[1] + 1) + 0.08 * (i - (n_recipes - 1) / 2)
            ax.plot(
                trials,
                np.nanmean(v, axis=0),
                marker=MARKERS[i % len(MARKERS)],
                ms=3,
                ls=STYLES[i % len(STYLES)],
                color=f"C{i}",
                label=recipe,
            )
            ax.fill_between(
                trials, np.nanmin(v, axis=0), np.nanmax(v, axis=0), color=f"C{i}", alpha=0.10
            )
        ax.set_xlabel("trial")
        ax.set_ylabel(q.replace("_", " "))
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].legend(fontsize=7)


def plot_comparison(
    curves: dict[str, dict[str, np.ndarray]], path: Path | str, quantities: Sequence[str]
) -> None:
    """All recipes on one figure: per quantity, each recipe's mean over sets (shaded min-max)."""
    n = len(quantities)
    fig, axes = plt.subplots(1, n, figsize=(4.4 * n, 3.6), squeeze=False)
    _comparison_row(axes[0], curves, quantities)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_map_comparison(
    curves: dict[str, dict[str, dict[str, np.ndarray]]],
    path: Path | str,
    quantities: Sequence[str],
) -> None:
    """One row per map (``curves[map][recipe][quantity]``, sets x trials): the recipes' mean
    curves on that map, as :func:`plot_comparison` draws them."""
    n, rows = len(quantities), len(curves)
    fig, axes = plt.subplots(rows, n, figsize=(4.4 * n, 3.4 * rows), squeeze=False)
    for row, (name, per_recipe) in zip(axes, curves.items(), strict=True):
        _comparison_row(row, per_recipe, quantities)
        row[0].set_title(name, loc="left", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_baseline(results: list[dict[str, Any]], path: Path | str, title: str) -> None:
    """A baseline's runs: success rate over the last 20 episodes, and every episode's total."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for i, res in enumerate(results):
        reached = np.array([r["reached_goal"] for r in res["rows"]], dtype=float)
        ret = np.array([r["total_reinforcement"] for r in res["rows"]])
        w = min(20, len(reached))
        ep = np.arange(w, len(reached) + 1)
        axes[0].plot(
            ep,
            np.convolve(reached, np.ones(w), "valid") / w,
            color=f"C{i}",
            label=f"seed {res['seed']}",
        )
        axes[1].plot(np.arange(1, len(ret) + 1), ret, ".", ms=2, color=f"C{i}")
    axes[0].axhline(0.8, ls="--", color="0.5", lw=1)
    axes[0].set(xlabel="episode (trial)", ylabel="success rate, last 20", ylim=(-0.05, 1.05))
    axes[1].axhline(-6.24, ls="--", color="0.5", lw=1, label="paper, last trial")
    axes[1].set(xlabel="episode (trial)", ylabel="total reinforcement")
    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _log_binned(values: np.ndarray, exact: int = 20, ratio: float = 1.3):
    """Trials 1..``exact`` as they are, then means over bins growing by ``ratio`` (x: the
    bin's middle trial): a curve of thousands of trials stays readable on a log axis."""
    n = len(values)
    xs = list(np.arange(1, min(exact, n) + 1, dtype=float))
    ys = list(values[: min(exact, n)])
    lo = exact
    while lo < n:
        hi = min(n, max(lo + 1, int(round(lo * ratio))))
        xs.append(float(np.sqrt((lo + 1) * hi)))
        ys.append(float(np.mean(values[lo:hi])))
        lo = hi
    return np.array(xs), np.array(ys)


def plot_learning_curves(
    curves: Mapping[str, Sequence[Sequence[dict[str, Any]]]],
    path: Path | str,
    title: str = "",
    optimum: float | None = None,
) -> None:
    """Learners on one axis per quantity, trials on a log scale: ``curves[label]`` is one trial
    table (rows with ``steps``, ``total_reinforcement``, ``reached_goal``) per seed; drawn is
    the mean over the seeds that ran each trial (beyond trial 20, over log-spaced bins)."""
    quantities = (
        ("steps", "actions per trial"),
        ("total_reinforcement", "total reinforcement per trial"),
        ("reached_goal", "reached the goal (fraction of seeds)"),
    )
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.0))
    for i, (label, runs) in enumerate(curves.items()):
        lengths = sorted({len(r) for r in runs})
        seeds = f"{len(runs)} seeds" + "".join(
            f"; {sum(len(r) >= n for r in runs)} to trial {n}" for n in lengths[1:]
        )
        for ax, (key, _) in zip(axes, quantities, strict=True):
            v = np.full((len(runs), lengths[-1]), np.nan)
            for k, run in enumerate(runs):  # a seed that ran fewer trials is missing after
                v[k, : len(run)] = [float(row[key]) for row in run]
            x, y = _log_binned(np.nanmean(v, axis=0))
            ax.plot(
                x,
                y,
                marker=MARKERS[i % len(MARKERS)],
                ms=3,
                lw=1.2,
                ls=STYLES[i % len(STYLES)],
                color=f"C{i}",
                label=f"{label} ({seeds})",
            )
    for ax, (_, name) in zip(axes, quantities, strict=True):
        ax.set_xscale("log")
        ax.axvline(20, ls=":", lw=1, color="0.5")
        ax.set(xlabel="trial (log scale; dotted: the paper's 20)", ylabel=name)
    if optimum is not None:
        axes[0].axhline(
            optimum, ls="--", lw=1, color="0.4", label=f"shortest path ({optimum:g} actions)"
        )
    axes[2].set_ylim(-0.05, 1.05)
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
