"""Bad inputs of `symrl train`, `evaluate`, `drive` (and `study --workers`): exit 2 and one line
naming the flag or field and its value, no traceback, nothing trained."""

from __future__ import annotations

import pytest

import symrl.train
from symrl.assembly import build_policy
from symrl.cli import main
from symrl.learner.config import load_config
from symrl.runs import save_checkpoint
from symrl.world.worldmap import load_map


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    root = tmp_path_factory.mktemp("inputs")
    afile = root / "afile"
    afile.write_text("not a folder")
    config = load_config("paper", [])
    checkpoint = root / "checkpoint.pt"
    save_checkpoint(checkpoint, build_policy(config), config, 0)  # untrained
    return {"FILE": str(afile), "CKPT": str(checkpoint), "ROOT": str(root)}


BIG = ["experts.capacity=1000000", "experts.max_neurons=1000000"]
CASES = [
    (["train", "paper", "--trials", "0"], "--trials 0: must be >= 1"),
    (["train", "paper", "--trials", "-3"], "--trials -3: must be >= 1"),
    (["train", "paper", "--trials", "x"], "argument --trials: invalid int value: 'x'"),
    (["train", "paper", "--seed", "-1"], "--seed -1: must be >= 0"),
    (["train", "paper", "--checkpoint-every", "0"], "--checkpoint-every 0"),
    (["train", "paper", "--logdir", "FILE"], "--logdir 'FILE': exists and is not a folder"),
    (["train", "paper", "--logdir", "FILE/run"], "--logdir 'FILE/run': cannot make it"),
    (["train", "paper", "--logdir", "ROOT/big", *BIG], "experts.capacity=1000000: 1 robot(s)"),
    (["train", "paper", "env.robot.sonar_cone_rays=100000"], "sonar_cone_rays must be an integer"),
    (["train", "paper", "update.gamma=2"], "gamma"),
    (["train", "nosuchrecipe"], "recipe 'nosuchrecipe'"),
    (["train"], "a RECIPE is needed"),
    (["evaluate", "ROOT/none.pt"], "checkpoint 'ROOT/none.pt': no such file"),
    (["evaluate", "FILE"], "checkpoint 'FILE': not a readable symrl checkpoint"),
    (["evaluate", "CKPT", "--seed", "-1"], "--seed -1: must be >= 0"),
    (["evaluate", "CKPT", "--out", "FILE"], "--out 'FILE': exists and is not a folder"),
    (["evaluate", "CKPT", "--start", "1,a"], "argument --start: '1,a'"),
    (["evaluate", "CKPT", "--start", "3.6,1,0"], "--start 3.6,1,0: reset: pose"),
    (["drive", "--start", "3.6,1.0,0"], "--start 3.6,1,0: reset: pose"),
    (["drive", "--start", "1,2,3,4"], "argument --start: '1,2,3,4'"),
    (["drive", "--start", "1,2,nan"], "argument --start: '1,2,nan'"),
    (["drive", "--seed", "-1"], "--seed -1: must be >= 0"),
    (["drive", "--out", "FILE"], "--out 'FILE': exists and is not a folder"),
    (["drive", "--map", "nosuchmap"], "map 'nosuchmap'"),
    (["drive", "--shield", "-1"], "ShieldConfig.margin"),
    (["study", "paper", "--workers", "0", "--sets", "1", "--trials", "1"], "--workers"),
]


@pytest.mark.parametrize(("argv", "message"), CASES, ids=[" ".join(c[0]) for c in CASES])
def test_bad_input_is_one_line_and_exit_2(argv, message, paths, capsys, monkeypatch):
    monkeypatch.setattr(symrl.train, "_available_memory", lambda: 1 << 30)  # 1 GiB
    argv = [paths.get(a, a) for a in argv]
    argv = [
        a.replace("FILE/", paths["FILE"] + "/").replace("ROOT/", paths["ROOT"] + "/") for a in argv
    ]
    for key, value in paths.items():
        message = message.replace(f"'{key}", f"'{value}")
    try:
        code = main(argv)
    except SystemExit as exit_:  # argparse
        code = exit_.code
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"symrl {argv[0]}: error: ") and message in err, err


def test_expert_storage_of_many_robots_is_refused_up_front(monkeypatch):
    monkeypatch.setattr(symrl.train, "_available_memory", lambda: 16 << 30)
    config = load_config("paper", [*BIG, "run.trials=1"])
    assert symrl.train.check_memory(config, 1, load_map(config.env.map)) < 4 << 30
    with pytest.raises(ValueError, match=r"10 robot\(s\) would preallocate 6.0 GiB") as err:
        symrl.train.train_batch(config, list(range(10)), progress=False)
    assert "\n" not in str(err.value)


def _train(argv, capsys):
    code = main(["train", *argv])
    return code, capsys.readouterr().err


def test_a_run_folder_another_run_writes_is_refused(tmp_path, capsys):
    from filelock import FileLock

    run = tmp_path / "run"
    run.mkdir()
    with FileLock(run / ".lock"):
        code, err = _train(["paper", "--trials", "1", "--logdir", str(run), "--overwrite"], capsys)
    assert code == 2 and "is writing it now" in err and "--logdir" in err
    assert not (run / "config.yaml").exists()  # nothing written
    assert _train(["paper", "--trials", "1", "--logdir", str(run)], capsys)[0] == 0


def test_resume_removes_a_killed_save_and_tensorboard_keeps_one_value_per_trial(tmp_path, capsys):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    from torch.utils.tensorboard import SummaryWriter

    run = tmp_path / "run"
    assert _train(["paper", "--trials", "1", "--logdir", str(run)], capsys)[0] == 0
    (run / "checkpoint.ptk3j2.tmp").write_bytes(b"")  # a save cut short by SIGKILL
    killed = SummaryWriter(str(run / "tb"))  # trial 2 logged, then the run was killed
    killed.add_scalar("trial/steps", 999.0, 2)
    killed.close()
    assert _train(["--resume", str(run), "--trials", "2"], capsys)[0] == 0
    assert not list(run.glob("*.tmp"))
    events = EventAccumulator(str(run / "tb"))
    events.Reload()
    steps = [(e.step, e.value) for e in events.Scalars("trial/steps")]
    assert [s for s, _ in steps] == [1, 2] and 999.0 not in [v for _, v in steps]


def test_resume_adopts_a_foreign_checkpoint_only_when_asked(tmp_path, capsys):
    import shutil

    ours, theirs = tmp_path / "ours", tmp_path / "theirs"
    assert _train(["paper", "--trials", "1", "--logdir", str(ours)], capsys)[0] == 0
    assert _train(["reflex_only", "--trials", "1", "--logdir", str(theirs)], capsys)[0] == 0
    shutil.copy(theirs / "checkpoint.pt", ours / "checkpoint.pt")
    code, err = _train(["--resume", str(ours), "--trials", "2"], capsys)
    assert code == 2 and "checkpoint.pt has recipe='reflex_only'" in err
    assert "config.yaml recipe='paper'" in err and "--adopt-checkpoint" in err
    assert _train(["--resume", str(ours), "--trials", "2", "--adopt-checkpoint"], capsys)[0] == 0
    assert "recipe: reflex_only" in (ours / "config.yaml").read_text()


def test_a_run_written_before_a_setting_was_added_resumes(tmp_path, capsys):
    """config.yaml of an older symrl lacks the settings added since; the checkpoint's config has
    their defaults. That is the same run; a recorded value that differs is not."""
    import yaml

    run = tmp_path / "run"
    assert _train(["paper", "--trials", "1", "--logdir", str(run)], capsys)[0] == 0
    recorded = yaml.safe_load((run / "config.yaml").read_text())
    del recorded["options"]["goal_scans"]
    (run / "config.yaml").write_text(yaml.safe_dump(recorded))
    assert _train(["--resume", str(run), "--trials", "2"], capsys)[0] == 0
    recorded = yaml.safe_load((run / "config.yaml").read_text())
    recorded["options"]["goal_scans"] = not recorded["options"]["goal_scans"]
    (run / "config.yaml").write_text(yaml.safe_dump(recorded))
    code, err = _train(["--resume", str(run), "--trials", "3"], capsys)
    assert code == 2 and "options.goal_scans" in err and "not this folder's run" in err


def test_ctrl_c_in_a_command_is_one_line(monkeypatch, capsys, tmp_path):
    import symrl.studies.plan

    def interrupted(args, world=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(symrl.studies.plan, "plan_command", interrupted)
    assert main(["plan", "--out", str(tmp_path / "plan")]) == 130
    assert capsys.readouterr().err == "symrl plan: stopped by Ctrl-C; what was finished is kept\n"


def test_a_negative_start_reaches_the_command():
    """argparse alone reads `--start -1.4,0,0` as a flag without its value."""
    from symrl.cli.parser import negative_values

    assert negative_values(["drive", "--start", "-1.4,0,0", "--seed", "-1"]) == [
        "drive",
        "--start=-1.4,0,0",
        "--seed",
        "-1",
    ]
