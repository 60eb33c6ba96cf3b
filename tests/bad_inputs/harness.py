"""Runs one bad input of the corpus (``corpus.yaml``) and says what became of it.

Every input runs in this process (``symrl.cli.main``, the API), under an alarm, and ends in one
of: ``one-line`` (refused with exit 2 or a ValueError / Gymnasium error whose message is one
line), ``multi-line`` (refused, but over several lines), ``traceback`` (another exception
escaped), ``accepted`` (it ran as if the input were fine) or ``hang`` (no answer in time).
``python tests/bad_inputs/audit.py`` counts them.
"""

from __future__ import annotations

import contextlib
import io
import math
import signal
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

CORPUS = Path(__file__).with_name("corpus.yaml")
TIMEOUT_S = 60


@dataclass
class Outcome:
    kind: str  # one-line, multi-line, traceback, accepted, hang
    text: str


def load_cases() -> list[dict[str, Any]]:
    """Every case of the corpus files (``corpus.yaml``, then ``corpus_*.yaml`` beside it, whose
    ids are prefixed with their name) as ``{section, id, input..., expect}``."""
    cases = []
    for path in [CORPUS, *sorted(CORPUS.parent.glob("corpus_*.yaml"))]:
        data = yaml.safe_load(path.read_text())
        prefix = "" if path == CORPUS else path.stem.removeprefix("corpus_") + ":"
        for section, entries in data.items():
            for k, entry in enumerate(entries):
                cases.append({"section": section, "id": f"{prefix}{section}-{k:03d}", **entry})
    return cases


class Alarm(Exception):
    pass


@contextlib.contextmanager
def _alarm(seconds: int):
    def ring(signum, frame):
        raise Alarm()

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


# --- fixtures: files the inputs name --------------------------------------------------------


def make_fixtures(root: Path) -> dict[str, str]:
    """The files and folders the corpus's placeholders stand for, made under ``root``."""
    from symrl.assembly import build_policy
    from symrl.cli import main
    from symrl.learner.config import load_config
    from symrl.runs import save_checkpoint

    root.mkdir(parents=True, exist_ok=True)
    (root / "afile").write_text("not a folder\n")
    (root / "adir").mkdir(exist_ok=True)
    config = load_config("paper", [])
    ckpt = root / "checkpoint.pt"
    save_checkpoint(ckpt, build_policy(config), config, 0)
    run = root / "run"
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        assert main(["train", "paper", "--trials", "1", "--logdir", str(run)]) == 0
    other = root / "other_run"  # a run of another recipe, whose checkpoint goes into a copy of run
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        assert main(["train", "reflex_only", "--trials", "1", "--logdir", str(other)]) == 0
    mixed = root / "mixed_run"
    mixed.mkdir(exist_ok=True)
    for name in ("config.yaml", "trials.csv"):
        (mixed / name).write_bytes((run / name).read_bytes())
    (mixed / "checkpoint.pt").write_bytes((other / "checkpoint.pt").read_bytes())
    (root / "plan_out").mkdir(exist_ok=True)
    for name in ("plan.json", "plan.png"):
        (root / "plan_out" / name).write_text("{}\n")
    (root / "drive_out").mkdir(exist_ok=True)
    (root / "drive_out" / "path.png").write_text("x\n")
    (root / "study_out").mkdir(exist_ok=True)
    (root / "study_out" / "table1.json").write_text("{}\n")
    for name in ("stopped_study", "stopped_ablate", "stopped_sweep"):  # a stopped run's folder,
        (root / name).mkdir(exist_ok=True)  # of settings no case gives
        (root / name / "stopped.json").write_text('{"recipe": "other", "sets": 99}\n')
    return {
        "FILE": str(root / "afile"),
        "DIR": str(root / "adir"),
        "CKPT": str(ckpt),
        "RUN": str(run),
        "MIXED": str(mixed),
        "ROOT": str(root),
        "PLANOUT": str(root / "plan_out"),
        "DRIVEOUT": str(root / "drive_out"),
        "STUDYOUT": str(root / "study_out"),
        "STOPPEDSTUDY": str(root / "stopped_study"),
        "STOPPEDABLATE": str(root / "stopped_ablate"),
        "STOPPEDSWEEP": str(root / "stopped_sweep"),
    }


def _fill(text: str, places: dict[str, str]) -> str:
    for key in sorted(places, key=len, reverse=True):
        text = text.replace(key, places[key])
    return text


# --- running one case -------------------------------------------------------------------------


def _cli(argv: list[str], locked: str | None = None) -> Outcome:
    """``symrl ARGV``; ``locked``: a folder another process holds the lock of meanwhile."""
    from symrl.cli import main
    from symrl.locks import lock_folder

    err, out = io.StringIO(), io.StringIO()
    held = lock_folder(locked, "--out") if locked else None
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(argv)
    except SystemExit as exit_:
        code = exit_.code if isinstance(exit_.code, int) else 2
    finally:
        if held is not None:
            held.release()
    text = err.getvalue().strip()
    if code == 0:
        return Outcome("accepted", out.getvalue().strip()[-200:])
    if "Traceback" in text:
        return Outcome("traceback", text[-300:])
    lines = [line for line in text.splitlines() if line.strip()]
    lines = [line for line in lines if not line.startswith("symrl: note:")]
    return Outcome("one-line" if len(lines) == 1 else "multi-line", text)


def _api_error(err: BaseException) -> Outcome:
    import gymnasium

    if isinstance(err, (ValueError, gymnasium.error.Error, gymnasium.error.ClosedEnvironmentError)):
        text = str(err)
        return Outcome("one-line" if "\n" not in text.strip() else "multi-line", text)
    return Outcome("traceback", f"{type(err).__name__}: {err}")


def _map_text(case: dict[str, Any]) -> str:
    if "text" in case:
        return case["text"]
    from importlib import resources

    base = yaml.safe_load((resources.files("symrl.world") / "maps" / "hailu2001.yaml").read_text())
    if "ring" in case:  # a round room of n corners, two regions
        n = int(case["ring"])
        a = np.linspace(0, 2 * math.pi, n, endpoint=False)
        base = {
            "name": "ring",
            "boundary": [[round(5 * math.cos(t), 6), round(5 * math.sin(t), 6)] for t in a],
            "start": {"x": -2.5, "y": 0.0},
            "goal": {"x": 2.5, "y": 0.0, "radius": 0.4},
            "regions": {
                "names": ["west", "east"],
                "lines": {"l": {"x": 0.0}},
                "rules": [{"region": "west", "when": ["x < l"]}, {"region": "east"}],
            },
        }
    if "regions" in case:  # a 100 m x 10 m hall cut into n regions by n - 1 lines
        n = int(case["regions"])
        base = {
            "name": "hall",
            "boundary": [[-50, -5], [50, -5], [50, 5], [-50, 5]],
            "start": {"x": -45.0, "y": 0.0},
            "goal": {"x": -40.0, "y": 0.0, "radius": 0.4},
            "regions": {
                "names": [f"r{i}" for i in range(n)],
                "lines": {f"l{i}": {"x": -50 + (i + 1) * 100 / n} for i in range(n - 1)},
                "rules": [
                    *({"region": f"r{i}", "when": [f"x < l{i}"]} for i in range(n - 1)),
                    {"region": f"r{n - 1}"},
                ],
            },
        }
    if "obstacles" in case or "segments" in case:  # a 40 m room of n pillars or n thin walls,
        k = int(case.get("obstacles", case.get("segments", 0)))  # its regions found (auto)
        side = int(math.ceil(math.sqrt(k)))
        cells = [(-18 + 36 * (i % side) / side, -18 + 36 * (i // side) / side) for i in range(k)]
        base = {
            "name": "pillars",
            "boundary": [[-20, -20], [20, -20], [20, 20], [-20, 20]],
            "start": {"x": -19.5, "y": -19.5},
            "goal": {"x": 19.5, "y": 19.5, "radius": 0.4},
        }
        if "obstacles" in case:
            base["obstacles"] = [
                [[x, y], [x + 0.1, y], [x + 0.1, y + 0.1], [x, y + 0.1]] for x, y in cells
            ]
        else:
            base["segments"] = [[[x, y], [x + 0.1, y]] for x, y in cells]
    if "square" in case:  # a square room of half-side L
        size = float(case["square"])
        base = {
            "name": "square",
            "boundary": [[-size, -size], [size, -size], [size, size], [-size, size]],
            "start": {"x": -1.0, "y": 0.0},
            "goal": {"x": 1.0, "y": 0.0, "radius": 0.4},
            "regions": {
                "names": ["west", "east"],
                "lines": {"l": {"x": 0.0}},
                "rules": [{"region": "west", "when": ["x < l"]}, {"region": "east"}],
            },
        }
    for path, value in (case.get("set") or {}).items():
        node = base
        parts = path.split(".")
        for part in parts[:-1]:
            node = node[int(part)] if isinstance(node, list) else node[part]
        last = parts[-1]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    for path in case.get("drop") or []:
        node = base
        parts = path.split(".")
        for part in parts[:-1]:
            node = node[part]
        del node[parts[-1]]
    return yaml.safe_dump(base, sort_keys=False)


def _paper_map_with(path: str, value: Any) -> dict[str, Any]:
    """The paper's map file's content with one field (dotted ``path``) set to ``value``: the
    map a checkpoint carries."""
    return yaml.safe_load(_map_text({"set": {path: value}}))


_CHECKPOINT_CHANGES: dict[str, Any] = {
    "count_1000": lambda d: d["policy"]["experts.count"].fill_(1000),
    "count_minus_5": lambda d: d["policy"]["experts.count"].fill_(-5),
    "means_as_int": lambda d: d["policy"].__setitem__(
        "experts.means", d["policy"]["experts.means"].long()
    ),
    "centres_as_double": lambda d: d["policy"].__setitem__(
        "experts.centres", d["policy"]["experts.centres"].double()
    ),
    "used_as_int": lambda d: d["policy"].__setitem__(
        "experts.used", d["policy"]["experts.used"].long()
    ),
    "choice_99": lambda d: d["policy"]["options.choice"].fill_(99),
    "choice_minus_7": lambda d: d["policy"]["options.choice"].fill_(-7),
    "visit_99": lambda d: d["policy"]["options.visit"].fill_(99),
    "actions_1e6": lambda d: d["policy"]["experts.actions"].fill_(1e6),
    "means_1e6": lambda d: d["policy"]["experts.means"].fill_(1e6),
    "taken_nan": lambda d: d["policy"]["experts.taken"].fill_(math.nan),
    "utilities_inf": lambda d: d["policy"]["experts.utilities"].fill_(math.inf),
    "temperature_minus_1": lambda d: d["policy"]["progress.temperature"].fill_(-1.0),
    "epsilon_2": lambda d: d["policy"]["options.critic.epsilon"].fill_(2.0),
    "trials_done_minus_1": lambda d: d["policy"]["progress.trials_done"].fill_(-1),
    "options_n_minus_1": lambda d: d["policy"]["options.critic.n"].fill_(-1),
    "rule_region_99": lambda d: d["policy"]["mapper.rule_region"].fill_(99),
    "mapper_threshold_moved": lambda d: d["policy"]["mapper.threshold"].add_(1.0),
    "reflex_peaks_changed": lambda d: d["policy"]["reflex.peaks"].mul_(0.5),
    "code_centres_shifted": lambda d: d["policy"]["code_centres"].add_(0.5),
    "temperature_dropped": lambda d: d["policy"].pop("progress.temperature"),
    "extra_entry": lambda d: d["policy"].__setitem__("bogus", torch.zeros(1)),
    "entry_not_tensor": lambda d: d["policy"].__setitem__("progress.temperature", [0.1]),
    "centres_wrong_shape": lambda d: d["policy"].__setitem__(
        "experts.centres", torch.zeros(1, 4, 3, 99)
    ),
    "q_wrong_shape": lambda d: d["policy"].__setitem__(
        "options.critic.q", torch.zeros(1, 9, 2, dtype=torch.float64)
    ),
    "best_total_nan": lambda d: d["policy"]["progress.best_total"].fill_(math.nan),
    "policy_a_list": lambda d: d.__setitem__("policy", [1, 2]),
    "config_dropped": lambda d: d.pop("config"),
    "config_a_list": lambda d: d.__setitem__("config", [1]),
    "config_bad_gamma": lambda d: d["config"]["update"].__setitem__("gamma", 2.0),
    "config_unknown_key": lambda d: d["config"]["update"].__setitem__("gama", 0.9),
    "config_bad_map": lambda d: (
        d.__setitem__("map", None),
        d["config"]["env"].__setitem__("map", "nosuchmap"),
    ),
    "map_content_broken": lambda d: d.__setitem__("map", {"boundary": 1}),
    "seed_a_string": lambda d: d.__setitem__("seed", "0"),
    "seed_a_bool": lambda d: d.__setitem__("seed", True),
    "format_1": lambda d: d.__setitem__("format", 1),
    "format_dropped": lambda d: d.pop("format"),
    "config_gamma_bool": lambda d: d["config"]["update"].__setitem__("gamma", True),
    "config_gamma_string": lambda d: d["config"]["update"].__setitem__("gamma", "0.9"),
    "config_noise_1e308": lambda d: d["config"]["env"]["robot"].__setitem__(
        "sonar_noise_std", 1e308
    ),
    "config_rate_1e308": lambda d: d["config"]["trial_gradient"].__setitem__("rate", 1e308),
    "config_peaks_short": lambda d: d["config"]["reflex"].__setitem__("peaks", [1.0]),
    "map_heading_degrees": lambda d: d.__setitem__("map", _paper_map_with("start.heading", 270)),
    "map_goal_tiny": lambda d: d.__setitem__("map", _paper_map_with("goal.radius", 1e-9)),
    "map_room_tiny": lambda d: d.__setitem__(
        "map",
        _paper_map_with("boundary", [[-1e-6, -1e-6], [1e-6, -1e-6], [1e-6, 1e-6], [-1e-6, 1e-6]]),
    ),
}


def _checkpoint(case: dict[str, Any], places: dict[str, str], tmp: Path) -> Path:
    path = tmp / f"{case['change']}.pt"
    source = Path(places["CKPT"])
    if case["change"] == "empty_file":
        path.write_bytes(b"")
    elif case["change"] == "text_file":
        path.write_text("config: 1\n")
    elif case["change"] == "truncated":
        path.write_bytes(source.read_bytes()[:1000])
    elif case["change"] == "not_a_dict":
        torch.save([1, 2, 3], path)
    else:
        data = torch.load(source, weights_only=True)
        _CHECKPOINT_CHANGES[case["change"]](data)
        torch.save(data, path)
    return path


def _env(case: dict[str, Any]) -> Outcome:
    import gymnasium

    import symrl
    from symrl.world.env import Hailu2001Env

    env: Any = Hailu2001Env() if not case.get("made") else gymnasium.make(symrl.ENV_ID)
    state = case.get("state", "reset")
    if state in ("reset", "closed"):
        env.reset(seed=0)
    if state == "closed":
        env.close()
    if state == "ended":
        env.reset(seed=0, options={"pose": (4.1, -1.5, -math.pi / 2)})
        env.step(np.array([0.0], np.float32))
    try:
        eval(
            case["call"],
            {"np": np, "math": math, "torch": torch, "Hailu2001Env": Hailu2001Env},
            {"env": env},
        )
    except Exception as err:  # noqa: BLE001 - sorted by kind
        return _api_error(err)
    return Outcome("accepted", case["call"])


def run_case(case: dict[str, Any], places: dict[str, str], tmp: Path) -> Outcome:
    """Run ``case`` (its files under ``tmp``) and say what became of it."""
    tmp.mkdir(parents=True, exist_ok=True)
    out = str(tmp / "out")
    section = case["section"]
    try:
        with _alarm(case.get("timeout", TIMEOUT_S)):
            if section == "cli":
                fill = {**places, "TMP": str(tmp)}
                locked = _fill(case["locked"], fill) if "locked" in case else None
                return _cli([_fill(a, fill) for a in case["argv"]], locked)
            if section == "overrides":
                return _cli(
                    ["train", case.get("recipe", "paper"), "--logdir", out, *case["overrides"]]
                )
            if section == "recipes":
                path = tmp / "recipe.yaml"
                if "keys" in case:  # a recipe of n keys (no aliases)
                    keys = "".join(f"  k{i}: {i}\n" for i in range(int(case["keys"])))
                    path.write_text(f"knowledge: regions\nupdate:\n{keys}")
                else:
                    path.write_text(case["text"])
                return _cli(["train", str(path), "--logdir", out])
            if section == "maps":
                path = tmp / "map.yaml"
                path.write_text(_map_text(case))
                command = case.get("command", "drive")
                argv = [command, "--map", str(path), "--out", out]
                if command == "drive":
                    argv.append("--no-noise")
                return _cli(argv)
            if section == "checkpoints":
                path = _checkpoint(case, places, tmp)
                return _cli(["evaluate", str(path), "--out", out])
            if section == "env":
                return _env(case)
            raise KeyError(section)
    except Alarm:
        return Outcome("hang", f"no answer in {case.get('timeout', TIMEOUT_S)} s")
    except Exception as err:  # noqa: BLE001 - an escaped exception is a traceback
        return Outcome("traceback", f"{type(err).__name__}: {err}")
