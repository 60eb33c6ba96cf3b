"""Regenerate RESULTS.md from the results folders the study commands wrote.

Run the commands in ``COMMANDS`` (they write under ``results/``, which git ignores), then
``python -m symrl.studies.report``: it copies the figures to ``docs/figures/`` and writes
``RESULTS.md`` with every table, the command that made it, its wall time and the paper's numbers
beside ours. A section whose results folder is missing says so instead of failing, so a partial
re-run (e.g. only ``symrl study paper`` after the recipe changed) just refreshes its numbers.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path
from typing import Any

COMMANDS = {
    "plan": "symrl plan --out results/plan",
    "study": "symrl ablate --recipes paper --sets 10 --trials 20 --seed 100 --out results/ablate",
    "ablate": "symrl ablate --sets 10 --trials 20 --seed 100 --out results/ablate",
    "ppo": "symrl baseline ppo --episodes {episodes} --seeds 100,101,102 "
    "--out results/baseline-ppo",
    "generalise": "symrl generalise --recipe {recipe} --sets 10 --trials 20 --seed 100 "
    "--workers 2 --out results/generalise-{recipe}",
}
"""The commands whose folders this report reads (the PPO budget is read from its summary)."""

PPO_EPISODES = 2000
"""The PPO budget that was started (used when the run was cut short and wrote no summary)."""

INTERPRETATION = Path(__file__).with_name("results_discussion.md")
"""Hand-written discussion appended to the generated report (what reproduces and what not)."""


def _load(path: Path) -> Any | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _fig(src: Path, figures: Path, name: str) -> str:
    """Copy a figure into docs/figures and return its Markdown image link (or a note)."""
    if not src.is_file():
        return f"*(figure {src} not produced yet)*"
    figures.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, figures / name)
    return f"![{name}](docs/figures/{name})"


def _section_plan(results: Path, figures: Path) -> list[str]:
    plan = _load(results / "plan" / "plan.json")
    out = ["## The optimum (`symrl plan`)", "", f"Command: `{COMMANDS['plan']}`", ""]
    if plan is None:
        return out + ["*Not run yet.*", ""]
    lb, walk, replay = plan["lower_bound"], plan["chord_walk"], plan["env_replay_noise_free"]
    out += [
        f"- Method: {plan['method']}; length error bound {plan['length_error_bound_m']:g} m.",
        f"- Shortest path keeping {plan['clearance_m']:.3f} m (body 0.26 + IR 0.056) from every "
        f"wall: **{plan['length_m']:.3f} m = {plan['actions']} actions** of 0.20 m "
        "(docs/ALGORITHM.md: 25 actions, 4.91 m).",
        "- Lower bound with the body radius only (a sweep between poses may pass closer than an "
        f"end pose): {lb['length_m']:.3f} m = {lb['actions']} actions; a walk of {walk['moves']} "
        f"0.20 m moves along the path has {walk['sweep_contacts']} sweep contacts and "
        f"{walk['virtual_collisions']} virtual collisions, so **{plan['actions']} actions is the "
        f"exact optimum** under the env's rules"
        + ("." if plan["optimum_actions_exact"] else " - NOT confirmed (see plan.json)."),
        f"- Replayed in the env without noise: {replay}. The shortest path hugs the door post, so "
        "its total reinforcement (f1 near walls) is far from the best reachable total: steps and "
        "reinforcement are optimised by different paths." if replay else "- (no env replay)",
        f"- Wall time {plan['wall_time_s']} s.",
        "",
        _fig(results / "plan" / "plan.png", figures, "plan.png"),
        "",
    ]
    return out


def _section_study(results: Path, figures: Path) -> list[str]:
    folder = results / "ablate" / "paper"
    out = ["## Table 1 and Figs 5-9: the `paper` recipe (`symrl study paper`)", "",
           f"Command: `{COMMANDS['study']}` (the same runs as `symrl study paper --sets 10 "
           "--trials 20 --seed 100`; its folder is `results/ablate/paper`)", ""]
    table = _load(folder / "table1.json")
    if table is None:
        return out + ["*Not run yet.*", ""]
    out += [
        (folder / "table1.md").read_text(),
        f"CPU time {table.get('wall_time_s')} s (wall, 2 "
        f"shared cores); seeds {table['seeds'][0]}-{table['seeds'][1]}.",
        "",
        _study_check(results, table),
        "",
        "Learning curves (Figs 7-9; mean over sets, bars min-max):",
        "",
        _fig(folder / "curves.png", figures, "study-paper-curves.png"),
        "",
        "First and final trajectories of set 0 (Fig 6):",
        "",
        _fig(folder / "trajectories.png", figures, "study-paper-trajectories.png"),
        "",
        "Paths with neuron-toggle ghosts, and the final controller from four other starts (Fig 5):",
        "",
        _fig(folder / "ghosts.png", figures, "study-paper-ghosts.png"),
        "",
    ]
    return out


def _study_check(results: Path, table: dict[str, Any]) -> str:
    """Was `symrl study paper` also run on its own, and did it give the same Table 1?"""
    alone = _load(results / "study-paper" / "table1.json")
    if alone is None:
        return "(`symrl study paper` was not run on its own.)"
    keys = ("neurons", "steps", "total_reinforcement", "collisions", "path_length")
    same = all(alone.get(k) == table.get(k) for k in keys) and alone["seeds"] == table["seeds"]
    return (
        f"`symrl study paper --sets 10 --trials 20 --seed 100 --workers 2` run on its own: wall "
        f"time {alone['wall_time_s']} s, code `{alone.get('code', '?')}`; its Table 1 is "
        + ("identical to the one above." if same else "DIFFERENT from the one above (see "
           "results/study-paper/table1.md).")
    )


def _section_ablate(results: Path, figures: Path) -> list[str]:
    from symrl.studies.ablation import summary_markdown

    folder = results / "ablate"
    out = ["## Ablations (`symrl ablate`)", "", f"Command: `{COMMANDS['ablate']}` (a recipe can be "
           "re-run alone with `--recipes NAME`; the folder keeps the others)", ""]
    summary = _load(folder / "summary.json")
    if summary is None:
        return out + ["*Not run yet.*", ""]
    cpu = ", ".join(
        f"{r} {s['wall_time_s']:.0f} s" for r, s in summary.items() if not r.startswith("_")
    )
    out += [
        summary_markdown(summary),
        "Mean ± std over sets. Steps and total reinforcement: per set the mean over its last 5 "
        "trials (a failed trial counts with its 200 actions). First success: first trial that "
        "reached the goal (sets that never did in brackets).",
        "",
        f"CPU time per recipe (sum over its sets): {cpu}. Wall time (2 workers): "
        + "; ".join(f"{', '.join(r['recipes'])}: {r['wall_time_s']:.0f} s"
                    for r in summary.get("_runs", []))
        + f". Seeds {summary['_seeds'][0]}-{summary['_seeds'][1]}.",
        "",
        _fig(folder / "comparison.png", figures, "ablate-comparison.png"),
        "",
    ]
    for recipe in ("paper_literal",):
        t = folder / recipe / "table1.md"
        if t.is_file():
            out += [t.read_text(), ""]
            name = f"ablate-{recipe}-curves.png"
            out += [_fig(folder / recipe / "curves.png", figures, name), ""]
    return out


def _section_ppo(results: Path, figures: Path) -> list[str]:
    folder = results / "baseline-ppo"
    data = _load(folder / "summary.json")
    episodes = data["runs"][0]["config"]["episodes"] if data else PPO_EPISODES
    out = ["## Baseline: PPO from TorchRL (`symrl baseline ppo`)", "",
           f"Command: `{COMMANDS['ppo'].format(episodes=episodes)}`", ""]
    if data is None:
        return out + [_ppo_partial(folder, figures)]
    cfg = data["runs"][0]["config"]
    out += [
        f"Settings: {cfg['frames_per_batch']} frames per update, {cfg['epochs']} epochs, "
        f"minibatch {cfg['minibatch']}, Adam lr {cfg['lr']}, gamma {cfg['gamma']}, GAE lambda "
        f"{cfg['lmbda']}, clip {cfg['clip']}, entropy {cfg['entropy_coef']}, "
        f"2x{cfg['hidden']} tanh MLPs, TanhNormal actor on [-pi, pi]; observation = 24 sonars "
        "+ goal (distance/5, angle/pi). Budget: "
        f"{cfg['episodes']} episodes (= trials). Wall time {data['wall_time_s']} s.",
        "",
        (folder / "summary.md").read_text(),
        _ppo_first20(folder),
        "",
        _fig(folder / "ppo.png", figures, "ppo.png"),
        "",
    ]
    return out


def _ppo_first20(folder: Path) -> str:
    """Successes in the first 20 episodes (our learner's budget), collisions early and late."""
    from symrl.runs import read_trials_csv

    rows = read_trials_csv(folder / "episodes.csv")
    out = []
    for seed in sorted({r["seed"] for r in rows}):
        mine = [r for r in rows if r["seed"] == seed]
        first, last = mine[:100], mine[-100:]
        out.append(
            f"Seed {int(seed)}: {sum(bool(r['reached_goal']) for r in mine[:20])}/20 reached the "
            f"goal in the first 20 episodes (our learner's budget); mean collisions per episode "
            f"{sum(r['collisions'] for r in first) / len(first):.2f} in the first 100 episodes, "
            f"{sum(r['collisions'] for r in last) / len(last):.2f} in the last 100."
        )
    return " ".join(out)


def _ppo_partial(folder: Path, figures: Path) -> str:
    """Summary (and learning-curve figure) of an unfinished PPO run from its per-episode logs."""
    from symrl.figures import plot_baseline
    from symrl.runs import read_trials_csv
    from symrl.studies.ppo import first_reliable

    logs = sorted(folder.glob("episodes-seed*.csv"))
    if not logs:
        return "*Not run yet.*\n"
    lines = ["*The run did not finish before the deadline; from its per-episode log:*", ""]
    runs = []
    for log in logs:
        rows = read_trials_csv(log)
        runs.append({"seed": int(rows[0]["seed"]) if rows else 0, "rows": rows})
        reached = [bool(r["reached_goal"]) for r in rows]
        last = rows[-20:]
        first = next((int(r["episode"]) for r in rows if r["reached_goal"]), None)
        lines.append(
            f"- {log.name}: {len(rows)} episodes ({int(rows[-1]['frames']) if rows else 0} env "
            f"steps), {sum(reached)} reached the goal; first success: {first or 'never'}; "
            f"first reliable (>= 80% of 20): {first_reliable(reached) or 'never'}; last 20: "
            f"{sum(bool(r['reached_goal']) for r in last)}/{len(last)} reached, mean steps "
            f"{sum(r['steps'] for r in last) / max(len(last), 1):.1f}, mean total reinforcement "
            f"{sum(r['total_reinforcement'] for r in last) / max(len(last), 1):.2f}. "
            f"In its first 20 episodes (our learner's budget): "
            f"{sum(reached[:20])}/{min(20, len(rows))} reached the goal."
        )
    if any(r["rows"] for r in runs):
        figures.mkdir(parents=True, exist_ok=True)
        plot_baseline([r for r in runs if r["rows"]], figures / "ppo.png",
                      "PPO (TorchRL) on symrl/Hailu2001-v0")
        lines += ["", "![ppo.png](docs/figures/ppo.png)"]
    return "\n".join(lines) + "\n"


def _section_generalise(results: Path, figures: Path) -> list[str]:
    out = ["## Generalisation (`symrl generalise`)", ""]
    for recipe in ("paper", "paper_literal"):
        folder = results / f"generalise-{recipe}"
        out += [f"### `{recipe}`", "", f"Command: `{COMMANDS['generalise'].format(recipe=recipe)}`",
                ""]
        data = _load(folder / "generalise.json")
        if data is None:
            out += ["*Not run yet.*", ""]
            continue
        out += [
            (folder / "generalise.md").read_text(),
            f"Wall time {data['wall_time_s']} s.",
            "",
            _fig(folder / "starts.png", figures, f"generalise-{recipe}-starts.png"),
            "",
            _fig(folder / "obstacle.png", figures, f"generalise-{recipe}-obstacle.png"),
            "",
        ]
    return out


def _provenance() -> str:
    """Which code made the numbers: the commit, and the last commit of the `paper` recipe."""
    import subprocess

    def git(*args: str) -> str:
        try:
            return subprocess.run(["git", *args], capture_output=True, text=True,
                                  check=True).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            return "unknown"

    recipe = git("log", "-1", "--format=%h %s", "--", "symrl/recipes/paper.yaml")
    return (f"Code at commit `{git('rev-parse', '--short', 'HEAD')}`; "
            f"`symrl/recipes/paper.yaml` last changed in `{recipe}`.")


def build(results: Path = Path("results"), figures: Path = Path("docs/figures")) -> str:
    """The whole RESULTS.md text (copies figures as a side effect)."""
    lines = [
        "# Results",
        "",
        "Generated by `python -m symrl.studies.report` from the folders the commands below wrote "
        "(`results/`, git-ignored); figures are copied to `docs/figures/`. All runs: noise on, "
        "seeds 100-109 (set k uses seed 100 + k), 2 CPU cores shared with other jobs, so wall "
        "times are upper bounds. The paper's numbers: Hailu (2001), Table 1 (real robot, 10 sets "
        "x 20 trials, last trial): neurons 82.5 (var 4.73), steps 27.7 (var 1.90), total "
        "reinforcement -6.24 (var 0.875).",
        "",
    ]
    lines += [_provenance(), ""]
    for section in (_section_plan, _section_study, _section_ablate, _section_ppo,
                    _section_generalise):
        lines += section(results, figures)
    if INTERPRETATION.is_file():
        lines += [INTERPRETATION.read_text()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Write RESULTS.md (``--out``) from ``--results``."""
    parser = argparse.ArgumentParser(prog="python -m symrl.studies.report", description=__doc__)
    parser.add_argument("--results", default="results")
    parser.add_argument("--figures", default="docs/figures")
    parser.add_argument("--out", default="RESULTS.md")
    args = parser.parse_args(argv)
    text = build(Path(args.results), Path(args.figures))
    Path(args.out).write_text(text)
    print(f"wrote {args.out} ({len(text.splitlines())} lines), figures in {args.figures}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
