"""Bad inputs of `symrl train`, `evaluate`, `drive` (and `study --workers`): exit 2 and one line
naming the flag or field and its value, no traceback, nothing trained."""

from __future__ import annotations

import pytest

import symrl.train
from symrl.cli import main
from symrl.learner.config import load_config
from symrl.learner.policy import MixtureOfExpertsPolicy
from symrl.runs import save_checkpoint
from symrl.world.worldmap import load_map


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    root = tmp_path_factory.mktemp("inputs")
    afile = root / "afile"
    afile.write_text("not a folder")
    config = load_config("paper", [])
    checkpoint = root / "checkpoint.pt"
    save_checkpoint(checkpoint, MixtureOfExpertsPolicy(config), config, 0)  # untrained
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
    argv = [a.replace("FILE/", paths["FILE"] + "/").replace("ROOT/", paths["ROOT"] + "/")
            for a in argv]  # fmt: skip
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
