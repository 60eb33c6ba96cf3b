"""The ``symrl`` command line: one subcommand per job, each a thin layer over the public API.

Parsing lives here; the work lives in the modules named by each handler, imported lazily so
``symrl --help`` is instant and a command only pays for the libraries it uses.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from symrl.locks import holding

START_HELP = (
    "start pose X,Y,HEADING_DEG (metres, metres, degrees; heading 0 if left out; negative "
    "values as --start -1.4,0,0 or --start=-1.4,0,0); default: the map's start"
)
MAX_COORD = 1e4
"""Largest |X|, |Y| of a pose given on the command line (metres), as in a map file."""
_YAML11_BOOLS = {"yes", "no", "on", "off"}
"""Words YAML 1.1 reads as booleans; an override spells them true / false."""


def parse_pose(text: str) -> tuple[float, float, float]:
    """Read ``X,Y,HEADING_DEG`` (metres, metres, degrees) or ``X,Y`` (heading 0); returns
    ``(x, y, heading)`` with the heading in radians, as the env and the API take it."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected X,Y[,HEADING_DEG] as finite numbers (metres, metres, degrees), "
            "e.g. 0,0.5,90"
        )
    if len(values) == 2:
        values.append(0.0)
    if max(abs(values[0]), abs(values[1])) > MAX_COORD or abs(values[2]) > 360:
        raise argparse.ArgumentTypeError(
            f"{text!r}: X and Y must lie within +-{MAX_COORD:g} m and HEADING_DEG within "
            "+-360 degrees"
        )
    return values[0], values[1], math.radians(values[2])


def format_pose(pose) -> str:
    """A pose ``(x, y, heading in radians)`` as printed: ``(x, y, heading deg)``."""
    x, y, h = (float(v) for v in pose)
    return f"({x:g}, {y:g}, {math.degrees(h):.0f} deg)"


def _one_line_errors(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Usage errors of ``parser`` as one line (``symrl CMD: error: ...``), exit 2."""

    def error(message: str):
        parser.exit(2, f"{parser.prog}: error: {message}\n")

    parser.error = error  # type: ignore[method-assign]
    return parser


@contextlib.contextmanager
def _naming_start(start):
    """A start pose the world refuses (in a wall, too near one) is an error of ``--start``."""
    try:
        yield
    except ValueError as err:
        if start is None or "pose" not in str(err):
            raise
        x, y, h = start
        raise ValueError(f"--start {x:g},{y:g},{math.degrees(h):g}: {err}") from None


def _output_folder(
    flag: str, path: str | Path, results: Sequence[str] = (), overwrite: bool = False,
    command: str = "",
) -> Path:
    """Check, before any work, that the output folder ``path`` of ``flag`` can be made and
    written, and that it holds none of the ``results`` files of an earlier run of ``command``
    unless ``overwrite`` (or the run was stopped after writing some: ``--resume`` finishes it):
    each fault one line. Nothing is created here."""
    import os

    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"{flag} {str(path)!r}: exists and is not a folder")
    probe = folder
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise ValueError(f"{flag} {str(path)!r}: cannot make it ({str(probe)!r} is a file)")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"{flag} {str(path)!r}: cannot write in {str(probe)!r} (read-only)")
    from symrl.studies.checkpointing import STOPPED_NAME

    held = [name for name in results if (folder / name).exists()]
    if held and not overwrite and not (folder / STOPPED_NAME).is_file():  # a stopped one: resume
        raise ValueError(
            f"{flag} {str(path)!r}: holds the results of an earlier `symrl {command}` "
            f"({', '.join(held)}); pass --overwrite to replace them, or another {flag}"
        )
    return folder


def _recipe_argument(recipe: str | None) -> None:
    """A folder given as RECIPE is a one-line error (the loader would say 'no such file')."""
    if recipe is not None and Path(recipe).is_dir():
        raise ValueError(
            f"recipe {recipe!r}: is a folder; give a recipe name (e.g. paper) or a YAML file"
        )


def _check_overrides(overrides: Sequence[str], taken: dict[str, str]) -> None:
    """Refuse, in one line, the ``key=value`` overrides that would be silently dropped or
    silently win: a key given twice, ``recipe=`` (the RECIPE argument names the recipe), a key
    a flag of the command sets (``taken``: key -> the flag), an empty mapping (mappings merge
    entry by entry, so ``{}`` changes nothing) and YAML 1.1's yes/no/on/off for booleans."""
    seen: dict[str, str] = {}
    for text in overrides:
        if "=" not in text:
            continue  # the loader's one-line "expected key=value"
        key, value = (part.strip() for part in text.split("=", 1))
        if key == "recipe":
            raise ValueError(
                f"override {text!r}: the recipe is the RECIPE argument (`symrl train "
                f"{value or 'NAME'}`), not a key"
            )
        if key in seen:
            raise ValueError(
                f"override {key!r} given twice ({seen[key]!r} and {text!r}); give it once"
            )
        seen[key] = text
        if key in taken:
            raise ValueError(f"override {text!r} conflicts with {taken[key]}; give one of them")
        if value.lower() in _YAML11_BOOLS:
            raise ValueError(f"override {text!r}: write true or false")
        if value.replace(" ", "") == "{}":
            raise ValueError(
                f"override {text!r}: an empty mapping changes nothing (mappings merge entry by "
                f"entry); set its entries, e.g. {key}.NAME=VALUE"
            )


def _plannable(source: Any) -> None:
    """Before any work: refuse a map too big for the planner and the sub-goal table, and say so
    when preparing them will take more than a second (see :func:`symrl.world.worldmap.
    check_plannable`). ``source``: a map name, file or loaded map."""
    from symrl.world.worldmap import WorldMap, check_plannable, load_map, planning_note

    world = source if isinstance(source, WorldMap) else load_map(source)
    check_plannable(world)
    note = planning_note(world)
    if note:
        print(f"symrl: note: {note}", file=sys.stderr)


def _drive(args: argparse.Namespace) -> int:
    from symrl.drive import drive_command
    from symrl.world.robot import RobotConfig

    _at_least("--seed", args.seed, 0)
    from symrl.knowledge.shield import ShieldConfig

    if args.shield is not None:
        ShieldConfig(margin=args.shield)  # its own checks first
    ir_range = RobotConfig().ir_range
    if args.shield is not None and math.isfinite(args.shield) and args.shield >= ir_range:
        raise ValueError(
            f"--shield {args.shield:g}: the margin must be below the IR range {ir_range:g} m "
            "(the shield sees walls only by their IR reflectance)"
        )
    _output_folder("--out", args.out, ("path.png", "trial.json"), args.overwrite, "drive")
    with holding(args.out, "--out"), _naming_start(args.start):
        return drive_command(args)


def _at_least(flag: str, value: int | None, low: int) -> None:
    """A numeric flag below its bound is a one-line input error."""
    if value is not None and value < low:
        raise ValueError(f"{flag} {value}: must be >= {low}")


def _STOP_SIGNALS() -> tuple[int, ...]:  # noqa: N802 - a constant, read when it is needed
    """Ctrl-C, SIGTERM and (where there is one) SIGHUP: a closed terminal stops a run too."""
    import signal

    return tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


def _stoppable(run: Any) -> int:
    """``run(signalled)`` with SIGINT, SIGTERM and SIGHUP only asking it to stop (``signalled`` gets
    their numbers; the run stops after its current step, with its state saved), from the start
    of the command on."""
    import signal

    signalled: list[int] = []
    handlers = {}

    def on_signal(signum: int, frame) -> None:
        signalled.append(signum)

    for sig in _STOP_SIGNALS():
        handlers[sig] = signal.signal(sig, on_signal)
    try:
        return int(run(signalled))
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


def _train(args: argparse.Namespace) -> int:
    """``symrl train`` (stoppable: see :func:`_stoppable`)."""
    return _stoppable(lambda signalled: _train_run(args, signalled))


def _train_run(args: argparse.Namespace, signalled: list[int]) -> int:
    import os
    import signal
    import time

    import numpy as np

    from symrl.learner.config import config_from_dict, config_to_dict, describe_keys, load_config
    from symrl.runs import load_resume, run_one
    from symrl.world.worldmap import load_map

    _recipe_argument(args.recipe)
    if args.help_keys:  # with a RECIPE (and key=value), that recipe's values
        print(describe_keys(load_config(args.recipe, args.overrides) if args.recipe else None))
        return 0
    _at_least("--trials", args.trials, 1)
    _at_least("--seed", args.seed, 0)
    _at_least("--checkpoint-every", args.checkpoint_every, 1)
    if args.adopt_checkpoint and args.resume is None:
        raise ValueError("--adopt-checkpoint: only with --resume RUN_DIR")
    state = None
    if args.resume is not None:
        given = [name for name, value in (
            ("RECIPE", args.recipe), ("--seed", args.seed), ("--map", args.map),
            ("--logdir", args.logdir), ("key=value", args.overrides), ("--overwrite",
                                                                      args.overwrite),
        ) if value]  # fmt: skip
        if given:
            raise ValueError(
                f"--resume {args.resume!r}: a resumed run keeps its own config; drop "
                f"{', '.join(given)} (only --trials may extend the budget)"
            )
        config, seed, state = load_resume(args.resume, adopt=args.adopt_checkpoint)
        if args.trials is not None:
            data = config_to_dict(config)
            data["run"]["trials"] = args.trials
            config = config_from_dict(data, recipe=config.recipe)
        done = len(state["trials"])
        if done >= config.run.trials:
            raise ValueError(
                f"--resume {args.resume!r}: the run has done {done} of {config.run.trials} "
                "trials; pass a larger --trials to go on"
            )
        from symrl.runs import load_checkpoint_world

        world = load_checkpoint_world(os.path.join(args.resume, "checkpoint.pt"))[2]
        logdir = args.resume
    else:
        if args.recipe is None:
            raise ValueError("train: a RECIPE is needed (e.g. `symrl train paper`)")
        _check_overrides(args.overrides or [], {key: f"{flag} {value}" for key, flag, value in (
            ("run.trials", "--trials", args.trials), ("run.seed", "--seed", args.seed),
            ("env.map", "--map", args.map),
        ) if value is not None})  # fmt: skip
        if args.logdir is not None:
            _output_folder("--logdir", args.logdir)
        overrides = list(args.overrides or [])
        for flag, key in (
            (args.trials, "run.trials"), (args.seed, "run.seed"), (args.map, "env.map"),
        ):  # fmt: skip
            if flag is not None:
                overrides.append(f"{key}={flag}")
        config = load_config(args.recipe, overrides)
        seed = config.run.seed
        stamp = time.strftime("%Y%m%d-%H%M%S") + f"-{time.time_ns() // 1000 % 1_000_000:06d}"
        logdir = args.logdir or f"runs/{config.recipe}__s{config.run.seed}__{stamp}-{os.getpid()}"
        world = load_map(config.env.map)
    if config.options.enabled:
        _plannable(world)

    result = run_one(
        config, logdir, world=world, overwrite=args.overwrite, resume=state, seed=seed,
        checkpoint_every=args.checkpoint_every or 1, stop=lambda: bool(signalled),
    )  # fmt: skip
    trials = result.trials
    if result.timings.get("stopped"):
        name = signal.Signals(signalled[0]).name
        if not trials and state is None:
            saved = "no trial finished, nothing to resume"
        else:
            saved = f"saved in {logdir}/; go on with: symrl train --resume {logdir}"
        print(
            f"symrl train: stopped by {name} after {len(trials)} of {config.run.trials} "
            f"finished trials; {saved}",
            file=sys.stderr,
        )
        return 128 + int(signalled[0])
    last = trials[-5:]
    print(
        f"{config.recipe} (seed {seed}): {len(trials)} trials, "
        f"{result.timings['steps_per_second']:.0f} steps/s; last trial {trials[-1]['steps']} "
        f"actions, total {trials[-1]['total_reinforcement']:.2f}, {trials[-1]['neurons']} "
        f"neurons; last-{len(last)} mean {np.mean([t['steps'] for t in last]):.1f} actions, "
        f"total {np.mean([t['total_reinforcement'] for t in last]):.2f}, "
        f"goal {sum(t['reached_goal'] for t in trials)}/{len(trials)}"
    )
    print(f"wrote {logdir}/ (config.yaml, trials.csv, checkpoint.pt, trajectory.png, tb/)")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib.pyplot as plt

    from symrl.evaluate import evaluate
    from symrl.figures import trajectory_figure
    from symrl.runs import load_checkpoint_world

    _at_least("--seed", args.seed, 0)
    from symrl.runs import CheckpointError

    if Path(args.checkpoint).is_dir():
        raise CheckpointError(
            f"checkpoint {args.checkpoint!r}: is a folder; pass the checkpoint.pt file in it"
        )
    from symrl.studies.baseline import load_baseline

    baseline = load_baseline(args.checkpoint)  # a baseline's checkpoint, else None
    learned_in = None
    if baseline is None:
        policy, config, learned_in = load_checkpoint_world(args.checkpoint)
    else:
        policy = baseline
    world = learned_in if baseline is None else baseline.world
    out = Path(args.out) if args.out else Path(args.checkpoint).parent
    _output_folder("--out", out, ("evaluate.png",), args.overwrite, "evaluate")
    trained_on = world
    if args.map is not None:
        from symrl.world.worldmap import load_map

        world = load_map(args.map)
    elif args.other_map:
        raise ValueError("--other-map: only with --map (the map to drive in)")
    other = args.map is not None and not _same_map(trained_on, world)
    if other and not args.other_map:
        raise ValueError(
            f"--map {args.map}: the controller learned in map {trained_on.name!r} (its regions "
            f"and goal); it would drive in {world.name!r} told the old map's. Pass --other-map "
            "to drive it there anyway"
        )
    if other:
        print(f"symrl evaluate: note: trained on map {trained_on.name!r}, driving in map "
              f"{world.name!r} (told {trained_on.name!r}'s regions and goal)",
              file=sys.stderr)  # fmt: skip
    with holding(out, "--out"), _naming_start(args.start):
        if baseline is not None:
            (record,) = baseline.evaluate([args.start], seed=args.seed, world=world)
        else:
            (record,) = evaluate(policy, config, starts=[args.start], seed=args.seed,
                                 world=world)  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    title = f"greedy: {record['steps']} actions, total {record['total_reinforcement']:.2f}"
    fig = trajectory_figure(world, record, title=title)
    fig.savefig(out / "evaluate.png", dpi=120)
    plt.close(fig)
    home = world.start
    start = args.start if args.start is not None else (home.x, home.y, home.heading)
    print(
        f"greedy trial from {format_pose(start)}: {record['steps']} actions, "
        f"total {record['total_reinforcement']:.2f}, "
        f"{record['collisions']} collisions, reached goal {record['reached_goal']}, "
        f"path {record['path_length']:.2f} m"
        + (f"; trained on {trained_on.name}, driven in {world.name}" if other else "")
    )
    print(f"wrote {out / 'evaluate.png'}")
    return 0


def _same_map(a: Any, b: Any) -> bool:
    """Whether two loaded maps are the same world (name, walls, start and goal)."""
    import numpy as np

    return bool(a.name == b.name and a.goal == b.goal and a.start == b.start
                and a.segments.shape == b.segments.shape
                and np.array_equal(a.segments, b.segments))  # fmt: skip


MAX_SETS = 10_000
"""Most sets of one study (each a robot with its own world and learner in memory)."""
MAX_WORKERS = 1024


def _sets_and_trials(args: argparse.Namespace) -> None:
    _at_least("--sets", args.sets, 1)
    _at_least("--trials", args.trials, 1)
    _at_least("--seed", args.seed, 0)
    for flag, value, high in (("--sets", args.sets, MAX_SETS), ("--trials", args.trials, 1_000_000),
                              ("--seed", args.seed, 2**63 - 1 - MAX_SETS),
                              ("--workers", args.workers, MAX_WORKERS)):  # fmt: skip
        if value is not None and value > high:
            raise ValueError(f"{flag} {value}: must be <= {high}")
    _at_least("--workers", args.workers, 1)


def _study(args: argparse.Namespace) -> int:
    from symrl.studies.repeatability import study_command

    _sets_and_trials(args)
    _recipe_argument(args.recipe)
    taken = {"run.trials": "--trials (the study's budget)", "run.seed": "--seed (set k: seed + k)"}
    if args.map is not None:
        taken["env.map"] = f"--map {args.map}"
    _check_overrides(args.overrides, taken)
    args.out = args.out or f"results/study-{Path(args.recipe).stem}"
    if args.resume and args.overwrite:
        raise ValueError("--resume goes on with the stopped study in --out, --overwrite starts "
                         "afresh: give one")  # fmt: skip
    _output_folder("--out", args.out, ("table1.json",), args.overwrite, "study")
    if args.map is None:
        from symrl.learner.config import load_config

        _plannable(load_config(args.recipe, args.overrides).env.map)
    else:
        _plannable(args.map)
    from symrl.studies import checkpointing

    settings = {"recipe": args.recipe, "sets": args.sets, "trials": args.trials,
                "seed": args.seed, "map": args.map, "overrides": list(args.overrides)}
    with holding(args.out, "--out"), checkpointing.running(
        args.out, "study", settings, args.resume, args.overwrite
    ) as going_on:
        if args.overwrite and not going_on:
            checkpointing.forget_kept(Path(args.out) / "sets")
        return study_command(args)


def _ablate(args: argparse.Namespace) -> int:
    from symrl.studies.ablation import ablate_command

    _sets_and_trials(args)
    if args.base is not None and not args.changes_of:
        raise ValueError(f"--base {args.base}: only with --changes-of (the recipe whose settings "
                         "it puts back); without it --base would be ignored")  # fmt: skip
    args.base = args.base or "paper_literal"
    for flag, value in (("--recipes", args.recipes),):
        if value is not None and not all(part.strip() for part in value.split(",")):
            raise ValueError(
                f"{flag} {value!r}: "
                + ("names no recipe" if not value.strip(", ") else "an empty name in the list")
                + "; name them (e.g. paper,reflex_only) or leave the flag out for all six"
            )
    _output_folder("--out", args.out)
    if args.maps is not None:
        from symrl.studies.ladder_worlds import ladder_worlds_command, parse_maps

        if not args.ladder or args.map != "hailu2001":  # a --map other than the default
            raise ValueError(f"--maps {args.maps!r}: runs the ladder on several worlds; give "
                             "it with --ladder and without --map")
        for name in parse_maps(args.maps):
            _plannable(name)
        return ladder_worlds_command(args)
    _plannable(args.map)
    if args.resume and not Path(args.out).is_dir():
        raise ValueError(f"--resume: --out {args.out!r} does not exist; nothing to go on with")
    with holding(args.out, "--out"):
        return ablate_command(args)


def _plan(args: argparse.Namespace) -> int:
    from symrl.studies.plan import plan_command

    for flag, value, low in (("--beam", args.beam, 1), ("--headings", args.headings, 4)):
        if not low <= value <= 100_000:
            raise ValueError(f"{flag} {value}: must be an integer from {low} to 100000")
    results = ("plan.json", "plan.png")
    if args.reward:
        results += ("reward_optimum.json", "reward_optimum.png")
    _output_folder("--out", args.out, results, args.overwrite, "plan")
    _plannable(args.map)
    with holding(args.out, "--out"), _naming_start(args.start):
        return plan_command(args)


def _baseline(args: argparse.Namespace) -> int:
    """``symrl baseline`` (stoppable with one worker: see :func:`_stoppable`)."""
    from symrl.studies.baseline import baseline_command

    if args.out is not None:
        _output_folder("--out", args.out)
    if args.workers != 1:  # worker processes keep their periodic checkpoints
        return baseline_command(args)
    return _stoppable(lambda signalled: baseline_command(args, signalled))


def _generalise(args: argparse.Namespace) -> int:
    from symrl.studies.generalisation import generalise_command

    _sets_and_trials(args)
    _output_folder("--out", args.out, ("generalise.json",), args.overwrite, "generalise")
    _plannable(args.map)
    with holding(args.out, "--out"):
        return generalise_command(args)


def _sweep(args: argparse.Namespace) -> int:
    from symrl.studies.sweep import sweep_command

    _check_overrides(args.overrides, {
        "run.trials": "--trials", "run.seed": "--seeds", "env.map": "--maps"})  # fmt: skip
    _output_folder("--out", args.out)
    for name in (args.maps or "").split(","):
        if name.strip():
            _plannable(name.strip())
    with holding(args.out, "--out"):
        return sweep_command(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="symrl",
        description="Symbolic structures in numeric reinforcement (Hailu, 2001): "
        "a robot that learns a short, safe path in a handful of trials. Outputs: "
        "`train` writes runs/RECIPE__sSEED__TIME/, every other command results/COMMAND.../ "
        "(see --out of each).",
    )
    _one_line_errors(parser)
    from symrl.about import __version__

    parser.add_argument("--version", action="version", version=f"symrl {__version__}",
                        help="print the version and exit")  # fmt: skip
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("drive", help="let the fuzzy reflex drive one trial and save its path")
    _one_line_errors(p)
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", default="results/drive",
                   help="output folder for path.png and trial.json (default results/drive)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a path.png / trial.json already in --out")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (default hailu2001)")
    p.add_argument("--no-noise", action="store_true", help="turn every noise source off")
    p.add_argument(
        "--shield",
        type=float,
        nargs="?",
        const=0.06,
        default=None,
        metavar="MARGIN",
        help="veto moves into walls with the IR shield (margin in m, below the IR range "
        "0.5 m; 0.06 if given without a value)",
    )
    p.set_defaults(handler=_drive)

    p = sub.add_parser(
        "train",
        help="train a recipe online, trial by trial",
        description="Train a recipe online. Config keys are overridden as key=value "
        "(e.g. update.gamma=0.9 shield.enabled=false); --help-keys lists every key with its "
        "default and meaning.",
    )
    _one_line_errors(p)
    p.add_argument("recipe", nargs="?", help="recipe name (paper, paper_literal, ...) or YAML file")
    p.add_argument("--trials", type=int, default=None, help="number of trials (recipe default)")
    p.add_argument("--seed", type=int, default=None, help="random seed (recipe default)")
    p.add_argument("--map", default=None, help="built-in map name or map file (env.map)")
    p.add_argument("--logdir", default=None, help="run folder (default runs/RECIPE__sSEED__TIME)")
    p.add_argument("--overwrite", action="store_true", help="replace a run already in --logdir")
    p.add_argument("--resume", default=None, metavar="RUN_DIR",
                   help="go on with the run in RUN_DIR from its last checkpoint (its own config; "
                   "--trials may extend the budget)")
    p.add_argument("--checkpoint-every", type=int, default=1, metavar="N",
                   help="write the resumable checkpoint every N trials (default 1; always at "
                   "the end and when stopped by Ctrl-C or SIGTERM)")
    p.add_argument("--adopt-checkpoint", action="store_true",
                   help="with --resume: go on even if checkpoint.pt's recipe, seed, map or "
                   "settings differ from the folder's config.yaml (the checkpoint's win)")
    p.add_argument("--help-keys", action="store_true",
                   help="list every config key with its value (RECIPE's and the overrides', "
                   "given one; else the defaults) and exit")
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_train)

    p = sub.add_parser("evaluate", help="drive a saved controller greedily and save its path")
    _one_line_errors(p)
    p.add_argument("checkpoint",
                   help="checkpoint file written by `symrl train` or `symrl baseline`")
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument("--seed", type=int, default=0, help="random seed for the world's noise")
    p.add_argument("--map", default=None,
                   help="drive in another map (default: its own); with --other-map")
    p.add_argument("--other-map", action="store_true",
                   help="with --map: drive in a map other than the one the controller learned "
                   "in (it keeps the learned map's regions and goal; the output names both)")
    p.add_argument("--out", default=None,
                   help="output folder for evaluate.png (default: beside the checkpoint)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an evaluate.png already in the output folder")
    p.set_defaults(handler=_evaluate)

    p = sub.add_parser("study", help="repeatability study: N sets x M trials (Table 1, Figs 5-9)")
    p.add_argument("recipe", help="recipe name (paper, paper_literal, ...) or YAML file")
    p.add_argument("--sets", type=int, default=10, help="sets, each a fresh learner (default 10)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes, each training its share of the sets as one batch "
                   "(default: one per CPU core; set k is the same run whatever the split)")
    p.add_argument("--seed", type=int, default=100, help="first seed; set k uses seed + k")
    p.add_argument("--map", default=None, help="built-in map name or map file (env.map)")
    p.add_argument("--out", default=None, help="results folder (default results/study-RECIPE)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a finished or stopped study in --out")
    p.add_argument("--resume", action="store_true",
                   help="go on with the study stopped in --out (Ctrl-C, SIGTERM, SIGHUP or a "
                   "kill): the same command and --resume give the table of a run never stopped")
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_study)

    p = sub.add_parser("ablate", help="the study for every recipe with the same seeds")
    p.add_argument("--sets", type=int, default=10, help="sets per recipe (default 10)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes, each training its share of the sets as one batch "
                   "(default: one per CPU core; set k is the same run whatever the split)")
    p.add_argument("--seed", type=int, default=100, help="first seed; set k uses seed + k")
    p.add_argument("--recipes", default=None,
                   help="comma-separated recipes (default: all six; with --changes-of: none)")
    p.add_argument("--changes-of", default=None, metavar="RECIPE",
                   help="RECIPE, then RECIPE with each setting in which it differs from --base "
                        "put back in turn, and with experts.learning=false; writes changes.md "
                        "(paired differences over the sets)")
    p.add_argument("--ladder", action="store_true",
                   help="the knowledge ladder: the best recipe of each rung (reflex_only, "
                   "paper_literal, paper, paper_passages, paper_map) on the same seeds; writes "
                   "ladder.md")
    p.add_argument("--base", default=None,
                   help="the recipe --changes-of puts settings back to (default paper_literal)")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (env.map; default hailu2001)")
    p.add_argument("--maps", default=None, metavar="M1,M2,...",
                   help="with --ladder: the ladder on each of these worlds (built-in names, "
                   "suite/world names or map files), one sub-folder each, and one table and "
                   "figure of them all (ladder-worlds.md, ladder-worlds.png)")
    p.add_argument("--out", default="results/ablate",
                   help="results folder (default results/ablate)")
    p.add_argument("--resume", action="store_true",
                   help="go on with the ablation stopped in --out (same settings)")
    p.set_defaults(handler=_ablate)

    p = sub.add_parser(
        "plan",
        help="shortest collision-free path to the goal (fewest actions; not the reward's "
        "optimum, which also pays for heading and wall distance)",
    )
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (default hailu2001)")
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument("--out", default="results/plan",
                   help="results folder for plan.json and plan.png (default results/plan)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a plan.json / plan.png already in --out")
    p.add_argument("--reward", action="store_true",
                   help="also search for the best total reinforcement of a noise-free trial "
                   "(writes reward_optimum.json and reward_optimum.png)")
    p.add_argument("--beam", type=int, default=100,
                   help="with --reward: partial sequences kept per action (default 100)")
    p.add_argument("--headings", type=int, default=144,
                   help="with --reward: headings tried per action (default 144, every 2.5 "
                   "degrees)")
    p.set_defaults(handler=_plan)

    p = sub.add_parser(
        "baseline",
        help="deep-RL baselines (SAC, PPO from TorchRL) on the same task, optionally given the "
        "paper's prior knowledge",
        description="Train SAC or PPO (TorchRL) on the paper's world, one run folder per seed "
        "(OUT/seed-S: config.yaml, trials.csv, tb/, checkpoint.pt for `symrl evaluate`). "
        "From scratch by default; --residual and --regions hand it the paper's priors. "
        "SAC defaults (Stable-Baselines3 / Haarnoja et al. 2018): buffer 1e6, batch 256, "
        "100 random steps first, Adam 3e-4, gamma 0.99, tau 0.005, 1 gradient step per "
        "transition, learned temperature, 2x256 ReLU, 1 env. PPO defaults (CleanRL): 2048 "
        "transitions per update from 8 envs, 10 epochs, minibatch 64, Adam 3e-4, gamma 0.99, "
        "GAE 0.95, clip 0.2, 2x64 tanh.",
    )
    _one_line_errors(p)
    p.add_argument("algorithm", choices=["sac", "ppo"], help="sac or ppo")
    p.add_argument("--episodes", type=int, default=20,
                   help="training budget in episodes (= trials; default 20, the paper's)")
    p.add_argument("--seeds", default="100", help="seeds: a range 100-104 and/or a list 100,105")
    p.add_argument("--residual", action="store_true",
                   help="act as the shielded fuzzy reflex (steering toward the goal) plus a "
                   "learned correction of at most --correction * pi")
    p.add_argument("--correction", type=float, default=None,
                   help="largest residual correction as a fraction of pi (default 0.25: 45 deg)")
    p.add_argument("--regions", action="store_true",
                   help="append the region id (one-hot, from the odometry pose) to the "
                   "observation")
    p.add_argument("--envs", type=int, default=None,
                   help="robots stepped together (default: sac 1, ppo 8)")
    p.add_argument("--workers", type=int, default=1,
                   help="seeds trained in parallel processes (default 1)")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (default hailu2001)")
    p.add_argument("--out", default=None,
                   help="results folder (default results/baseline-ALGO-VARIANT)")
    p.add_argument("--overwrite", action="store_true", help="replace runs already in --out")
    p.add_argument("--resume", action="store_true",
                   help="go on with the runs already in --out (same settings; --episodes may "
                   "extend the budget); seeds without a run there start fresh")
    p.add_argument("--checkpoint-every", type=int, default=50, metavar="N",
                   help="save the whole run state every N trials (default 50), on Ctrl-C / "
                   "SIGTERM (one worker) and at the end")
    p.set_defaults(handler=_baseline)

    p = sub.add_parser(
        "generalise", help="learned controller from other starts, new obstacle, noise"
    )
    p.add_argument("--recipe", default="paper",
                   help="recipe name or YAML file (default paper)")
    p.add_argument("--sets", type=int, default=5, help="sets, each a fresh learner (default 5)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes, each training its share of the sets as one batch "
                   "(default: one per CPU core; set k is the same run whatever the split)")
    p.add_argument("--seed", type=int, default=100,
                   help="first seed; set k uses seed + k (default 100)")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (env.map; default hailu2001)")
    p.add_argument("--out", default="results/generalise",
                   help="results folder (default results/generalise)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results of an earlier run in --out")
    p.set_defaults(handler=_generalise)

    p = sub.add_parser(
        "sweep",
        help="a grid of runs: recipes x seeds x maps, one run folder each, one merged table",
        description="Train every recipe x seed x map (the key=value overrides apply to all) "
        "into OUT/runs/RECIPE__MAP__sSEED/ as `symrl train` writes it; runs already finished "
        "there are kept. Writes OUT/summary.md, summary.json and comparison.png.",
    )
    _one_line_errors(p)
    p.add_argument("--recipes", required=True, help="comma-separated recipes (paper,reflex_only)")
    p.add_argument("--seeds", required=True, help="seeds: a range 100-102 and/or a list 100,105")
    p.add_argument("--maps", default="hailu2001",
                   help="comma-separated built-in maps or map files (default hailu2001)")
    p.add_argument("--trials", type=int, default=20, help="trials per run (default 20)")
    p.add_argument("--workers", type=int, default=None,
                   help="parallel runs (default: 1 local, every CPU with ray)")
    p.add_argument("--backend", choices=["local", "ray"], default="local",
                   help='local process pool (default) or Ray tasks (pip install "symrl[ray]")')
    p.add_argument("--out", required=True, help="sweep folder")
    p.add_argument("--resume", action="store_true",
                   help="go on with the sweep stopped in --out: its unfinished runs go on from "
                   "their last checkpoints")
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides for all")
    p.set_defaults(handler=_sweep)
    for each in sub.choices.values():
        _one_line_errors(each)
    return parser


def _without_ray() -> None:
    """Keep Ray out of this process: torchrl imports it at import time whenever it is
    installed (its Ray replay buffer), which is about a quarter of the import time of every
    command (``python -X importtime``); only ``symrl sweep --backend ray`` uses it."""
    sys.modules.setdefault("ray", None)  # type: ignore[arg-type]  # `import ray` now fails


_TRAINING = ("symrl.train", "symrl.learner.policy", "symrl.learner.loss", "symrl.world.batched_env")
_PRELOAD = {
    "train": (*_TRAINING, "symrl.runs"),
    "evaluate": (*_TRAINING, "symrl.evaluate", "symrl.figures"),
    "study": (*_TRAINING, "symrl.studies.repeatability"),  # matplotlib: in symrl.drawing's process
    "ablate": (*_TRAINING, "symrl.studies.ablation", "symrl.figures"),
    "generalise": (*_TRAINING, "symrl.studies.generalisation", "symrl.figures"),
}
"""The modules a command imports anyway (torch, tensordict, torchrl, matplotlib under them)."""


def _preload(command: str) -> None:
    """Import what ``command`` needs with the garbage collector paused, then freeze those
    objects out of later collections: the imports create about 450,000 long-lived objects,
    and collecting while they arrive (full passes over all of them, several times) cost
    about 0.6 s of the import time here (measured with and without ``gc.disable()``)."""
    import gc
    import importlib

    modules = _PRELOAD.get(command, ())
    if not modules:
        return
    gc.disable()
    try:
        for name in modules:
            importlib.import_module(name)
    finally:
        gc.freeze()
        gc.enable()


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; ``argv`` None: this process is the command (``symrl ...``), which
    then also keeps Ray out (unless it is ``sweep``), imports what the command needs with the
    garbage collector paused."""
    import time

    started = time.perf_counter()
    command_line = argv is None
    parser = build_parser()
    argv = _negative_values(sys.argv[1:] if argv is None else list(argv))
    args, extra = parser.parse_known_args(argv)
    args.started = started  # the command's wall time is counted from here
    # argparse cannot take positional key=value overrides after options (`study R --sets 2 k=v`)
    if extra:
        if hasattr(args, "overrides") and all("=" in e and not e.startswith("-") for e in extra):
            args.overrides = [*args.overrides, *extra]
        elif hasattr(args, "overrides") and not extra[0].startswith("-"):
            parser.error(
                f"argument {extra[0]!r}: expected key=value (an override such as "
                "update.gamma=0.9)"
            )
        else:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    if command_line:
        if args.command != "sweep":
            _without_ray()
        if args.command == "study":  # its figures: drawn by a process importing matplotlib now
            from symrl import drawing

            drawing.start()
        _preload(args.command)
    try:
        _no_empty_values(args)
        with _signals_stop(args.command in _RESUMABLE):
            code = int(args.handler(args) or 0)
    except (ValueError, FileNotFoundError, FileExistsError) as err:
        # Configuration and input errors: one clear line, no deep traceback.
        print(f"symrl {args.command}: error: {_one_line(err)}", file=sys.stderr)
        code = 2
    except OSError as err:  # a file or folder the command cannot read or write
        where = f"{err.filename!r}: " if err.filename else ""
        print(f"symrl {args.command}: error: {where}{err.strerror or err}", file=sys.stderr)
        code = 2
    except KeyboardInterrupt as err:  # a command that does not catch Ctrl-C itself
        import signal

        signum = int(getattr(err, "signum", signal.SIGINT))
        name = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
        if args.command in _RESUMABLE:
            kept = (f"its progress is saved in {args.out}/ (all but the last few seconds); go on "
                    "with the same command and --resume")  # fmt: skip
        else:
            kept = "what was finished is kept"
        print(f"symrl {args.command}: stopped by {name}; {kept}", file=sys.stderr)
        code = 128 + signum
    return code


_NAMED_VALUES = {
    "out": "--out", "logdir": "--logdir", "map": "--map", "resume": "--resume",
    "checkpoint": "CHECKPOINT", "recipe": "RECIPE", "base": "--base", "changes_of": "--changes-of",
}  # fmt: skip
"""The arguments naming a file or folder, by the flag that gives them (lists such as --recipes
have their own checks)."""


def _no_empty_values(args: argparse.Namespace) -> None:
    """An empty path or list (``--out ""``) is an error, not the default or the current
    folder."""
    for name, flag in _NAMED_VALUES.items():
        value = getattr(args, name, None)
        if isinstance(value, str) and not value.strip():
            if name == "recipe" and args.command in ("generalise",):
                flag = "--recipe"
            raise ValueError(f"{flag} {value!r}: empty; give a name or path (or leave the flag "
                             "out for its default)")  # fmt: skip


_RESUMABLE = ("study", "ablate", "sweep")
"""The commands that save their progress as they go and take --resume."""


class _Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, stopping a command as Ctrl-C does."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _signals_stop(on: bool):
    """With ``on``: Ctrl-C, SIGTERM and SIGHUP stop the command at once, its worker processes
    too (each is sent SIGINT, as a terminal's Ctrl-C does), so it ends with its stop message
    and its saved progress instead of dying silently or waiting for its workers."""
    import os
    import signal

    if not on:
        yield
        return

    def stop(signum: int, frame: Any) -> None:
        import multiprocessing

        if os.getpid() != main_pid:  # a worker forked with this handler: the command reports
            os._exit(128 + signum)  # the stop; its progress is in the files it saved
        for child in multiprocessing.active_children():
            with contextlib.suppress(OSError):
                os.kill(child.pid, signal.SIGINT)
        raise _Stopped(signum)

    main_pid = os.getpid()
    old = {s: signal.signal(s, stop) for s in _STOP_SIGNALS()}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)


def _one_line(err: BaseException) -> str:
    """An input error's message on one line."""
    return " ".join(str(err).split())


_NEGATIVE_VALUE = re.compile(r"-\.?\d[\d.eE+-]*(,[^,]*)+")
"""A negative pose such as ``-1.4,0,0``, which argparse would take for an option."""


def _negative_values(argv: list[str]) -> list[str]:
    """``--start -1.4,0,0`` as ``--start=-1.4,0,0``: argparse reads a value that starts with
    a minus sign and is not a plain number as an option (and then says the flag is missing
    its argument)."""
    out: list[str] = []
    for token in argv:
        previous = out[-1] if out else ""
        if previous.startswith("--") and "=" not in previous and _NEGATIVE_VALUE.fullmatch(token):
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out


if __name__ == "__main__":
    sys.exit(main())
