"""Training end to end: robot k of a batch is the same run as its seed alone, a short run learns,
checkpoints round-trip (and every broken file is one clear error), the command line."""

from __future__ import annotations

import csv
import math

import pytest
import torch

from symrl.assembly import build_policy
from symrl.cli import main
from symrl.evaluate import evaluate
from symrl.learner.config import load_config
from symrl.runs import CheckpointError, load_checkpoint, save_checkpoint
from symrl.train import make_env, train, train_batch

SEEDS = (3, 8)
RECIPE = "paper_map"  # options, shield and residual experts: every per-robot stream is in play


def _config(seed: int, trials: int = 2, recipe: str = RECIPE):
    return load_config(recipe, [f"run.trials={trials}", f"run.seed={seed}"])


def _scalars(trials: list[dict]) -> list[dict]:
    """Every scalar column of a trial table (the path and the ghosts are lists)."""
    return [{k: v for k, v in t.items() if not isinstance(v, list)} for t in trials]


@pytest.fixture(scope="module")
def alone():
    """Each seed trained on its own (a batch of one robot)."""
    return {seed: train(_config(seed), progress=False) for seed in SEEDS}


@pytest.fixture(scope="module")
def batch():
    return train_batch(_config(SEEDS[0]), list(SEEDS), progress=False)


def test_robot_k_of_a_batch_is_its_seed_alone(alone, batch):
    for k, seed in enumerate(SEEDS):
        result = batch[k]
        assert result.seed == seed and len(result.trials) == 2
        assert _scalars(result.trials) == _scalars(alone[seed].trials)
        assert [t["path"] for t in result.trials] == [t["path"] for t in alone[seed].trials]
        mine, theirs = result.policy.state_dict(), alone[seed].policy.state_dict()
        assert mine.keys() == theirs.keys()
        for key in mine:
            assert torch.equal(mine[key], theirs[key]), key


def test_batch_order_does_not_matter(batch):
    swapped = train_batch(_config(SEEDS[0]), list(reversed(SEEDS)), progress=False)
    assert [r.seed for r in swapped] == list(reversed(SEEDS))
    for k in range(len(SEEDS)):
        assert _scalars(swapped[-1 - k].trials) == _scalars(batch[k].trials)


def test_same_seed_same_table_other_seed_other_table(alone):
    seed = SEEDS[0]
    again = train(_config(seed), progress=False)
    assert _scalars(again.trials) == _scalars(alone[seed].trials)
    assert [t["path"] for t in again.trials] == [t["path"] for t in alone[seed].trials]
    assert _scalars(alone[SEEDS[1]].trials) != _scalars(alone[seed].trials)


def test_trial_records(alone):
    result = alone[SEEDS[0]]
    policy = result.policy
    for n, t in enumerate(result.trials, 1):
        assert t["trial"] == n and t["steps"] == len(t["path"]) - 1
        assert t["neurons"] == sum(t[f"neurons_{name}"] for name in policy.expert_names)
        assert 1 <= len(t["ghosts"]) <= t["steps"]
        assert t["path_length"] == pytest.approx(t["steps"] * 0.2, rel=0.1)
        assert isinstance(t["reached_goal"], bool) and t["collisions"] >= 0
        assert any(key.startswith("option_") for key in t)
    assert result.trials[-1]["neurons"] == int(policy.neurons().sum()) > 0
    assert policy.batch == 1 and int(policy.progress.trials_done[0]) == 2
    assert float(policy.progress.temperature[0]) == pytest.approx(0.1 * 0.85**2)


def test_trial_record_shows_the_temperature_the_trial_explored_with(alone):
    # paper: T0 = 0.1, cooled x0.85 after each trial
    temperatures = [t["temperature"] for t in alone[SEEDS[0]].trials]
    assert temperatures == pytest.approx([0.1, 0.085])


def test_a_short_run_learns():
    """``paper`` (whose trial 1 folds into the concave corner; ``paper_map``'s first trial is
    already on the route): the mean total of trials 4-5 beats trial 1 on each seed."""
    results = train_batch(_config(0, trials=5, recipe="paper"), [0, 4], progress=False)
    for result in results:
        totals = [t["total_reinforcement"] for t in result.trials]
        assert sum(totals[3:]) / 2 > totals[0] + 1.5, (result.seed, totals)
        assert all(t["reached_goal"] for t in result.trials[3:])


def test_reflex_only_grows_nothing():
    result = train(
        load_config("reflex_only", ["run.trials=1", "env.max_actions=60"]), progress=False
    )
    assert result.trials[0]["neurons"] == 0 and result.trials[0]["replaced"] == 0


def test_env_specs():
    from torchrl.envs.utils import check_env_specs

    env = make_env(load_config("paper_map"), [0, 1])
    check_env_specs(env, seed=0)
    td = env.reset()
    assert td["true_pose"].dtype == torch.float64 and td["collision"].dtype == torch.bool
    assert td.batch_size == (2,)
    env.close()


# -- checkpoints ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def checkpoint(alone, tmp_path_factory):
    seed = SEEDS[0]
    path = tmp_path_factory.mktemp("ckpt") / "checkpoint.pt"
    save_checkpoint(path, alone[seed].policy, alone[seed].config, seed)
    return path


def test_checkpoint_round_trip_gives_the_same_greedy_record(alone, checkpoint):
    result = alone[SEEDS[0]]
    policy, config = load_checkpoint(checkpoint)
    assert config == result.config
    saved = result.policy.state_dict()
    for key, value in policy.state_dict().items():
        assert torch.equal(value, saved[key]), key
    assert policy.options is not None and policy.shield is not None
    assert policy.reflex.config == result.config.reflex
    loaded = evaluate(policy, config, seed=5)
    in_memory = evaluate(result.policy, result.config, seed=5)
    assert loaded == in_memory
    assert policy.neurons().tolist() == result.policy.neurons().tolist()  # greedy grows nothing
    # other starts, side by side in one batch
    starts = [None, (0.0, 1.0, 0.5)]
    assert evaluate(policy, config, starts=starts, seed=5)[0] == loaded[0]


def test_evaluating_side_by_side_is_evaluating_each_alone():
    """A batch of greedy trials from several starts gives each start's record alone, also
    when the trials end at different steps."""
    config = load_config("reflex_only")
    policy = build_policy(config)
    starts = [(0.0, 0.0, 0.0), (2.5, -1.5, 0.0)]
    both = evaluate(policy, config, starts=starts, noise=False)
    assert both[0]["steps"] != both[1]["steps"]
    for k, start in enumerate(starts):
        (alone,) = evaluate(policy, config, starts=[start], noise=False)
        assert both[k] == alone, k


def _broken(tmp_path, name: str, content: bytes) -> str:
    path = tmp_path / name
    path.write_bytes(content)
    return str(path)


def _rewritten(checkpoint, tmp_path, name: str, change) -> str:
    data = torch.load(checkpoint, weights_only=True)
    change(data)
    path = tmp_path / name
    torch.save(data, path)
    return str(path)


def _assert_one_line_error(path: str, *words: str) -> None:
    with pytest.raises(CheckpointError) as err:
        load_checkpoint(path)
    message = str(err.value)
    assert path in message and "\n" not in message, message
    for word in words:
        assert word in message, message


def test_unreadable_checkpoint_files(checkpoint, tmp_path):
    whole = checkpoint.read_bytes()
    g = torch.Generator().manual_seed(0)
    noise = bytes(torch.randint(0, 256, (4096,), generator=g, dtype=torch.uint8).tolist())
    _assert_one_line_error(_broken(tmp_path, "truncated.pt", whole[: len(whole) // 2]))
    _assert_one_line_error(_broken(tmp_path, "empty.pt", b""))
    _assert_one_line_error(_broken(tmp_path, "random.pt", noise))
    _assert_one_line_error(_broken(tmp_path, "text.pt", b"config: 1\n"))
    _assert_one_line_error(str(tmp_path / "missing.pt"), "no such file")
    other = tmp_path / "other.pt"
    torch.save({"weights": torch.zeros(3)}, other)
    _assert_one_line_error(str(other), "not written by symrl")


def test_checkpoint_whose_weights_do_not_fit_its_config(checkpoint, tmp_path):
    def codes(data):
        data["config"]["experts"]["goal_codes"] = 4

    def partition(data):
        data["config"]["gate"]["partition"] = False

    def missing(data):
        del data["policy"]["progress.temperature"]

    for change in (codes, partition, missing):
        path = _rewritten(checkpoint, tmp_path, f"{change.__name__}.pt", change)
        _assert_one_line_error(path, "do not match")


def test_checkpoint_with_non_finite_weights(checkpoint, tmp_path):
    def nan(data):
        data["policy"]["experts.utilities"][0, 0, 0] = math.nan

    def inf(data):
        data["policy"]["experts.centres"][0, 0, 0, 0] = math.inf

    def nan_best(data):
        data["policy"]["progress.best_total"][0] = math.nan

    for change, key in (
        (nan, "experts.utilities"),
        (inf, "experts.centres"),
        (nan_best, "best_total"),
    ):
        path = _rewritten(checkpoint, tmp_path, f"{change.__name__}.pt", change)
        _assert_one_line_error(path, "non-finite", key)


def test_checkpoint_with_a_bad_config_or_format(checkpoint, tmp_path):
    def unknown_key(data):
        data["config"]["update"]["gama"] = 0.9

    def old_format(data):
        data["format"] = 2

    path = _rewritten(checkpoint, tmp_path, "key.pt", unknown_key)
    _assert_one_line_error(path, "update.gama")
    _assert_one_line_error(_rewritten(checkpoint, tmp_path, "old.pt", old_format), "format 2")


def test_checkpoint_with_malformed_entries(checkpoint, tmp_path):
    def config_not_a_mapping(data):
        data["config"] = "paper_map"

    def policy_not_a_mapping(data):
        data["policy"] = [1, 2]

    def seed_not_a_number(data):
        data["seed"] = "abc"

    for change in (config_not_a_mapping, policy_not_a_mapping, seed_not_a_number):
        _assert_one_line_error(_rewritten(checkpoint, tmp_path, f"{change.__name__}.pt", change))


# -- the command line -----------------------------------------------------------------------


def test_train_command_writes_the_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["train", "paper_map", "--trials", "2", "--seed", "1", "--logdir", str(out)]
    assert main(args) == 0
    for name in ("config.yaml", "trials.csv", "checkpoint.pt", "trajectory.png"):
        assert (out / name).is_file(), name
    assert list((out / "tb").glob("events.out.tfevents.*"))
    with open(out / "trials.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["trial"] for r in rows] == ["1", "2"]
    assert {
        "steps",
        "total_reinforcement",
        "collisions",
        "shielded",
        "reached_goal",
        "neurons",
        "temperature",
        "replaced",
        "path_length",
        "neurons_room",
        "option_room",
    } <= set(rows[0])
    assert "paper_map (seed 1)" in capsys.readouterr().out
    policy, config = load_checkpoint(out / "checkpoint.pt")
    assert config.run.seed == 1 and config.run.trials == 2
    # what the robot was told, in the checkpoint, config.yaml and the agent it rebuilds
    assert config.knowledge == "map" and policy.knowledge.rung == "map"
    assert "knowledge: map" in (out / "config.yaml").read_text()
    assert int(policy.neurons().sum()) == int(rows[-1]["neurons"])
    # the folder holds a run: refused unless --overwrite
    assert main(args) == 2
    assert "--overwrite" in capsys.readouterr().err
    first_events = set((out / "tb").glob("events.out.tfevents.*"))
    again = ["train", "reflex_only", "--trials", "1", "--logdir", str(out), "env.max_actions=5"]
    assert main([*again, "--overwrite"]) == 0
    with open(out / "trials.csv") as fh:
        assert [r["steps"] for r in csv.DictReader(fh)] == ["5"]
    _, config = load_checkpoint(out / "checkpoint.pt")
    assert config.recipe == "reflex_only"
    # the replaced run leaves nothing behind: TensorBoard shows the new run only
    assert not first_events & set((out / "tb").glob("events.out.tfevents.*"))


def test_train_command_errors_and_help_keys(tmp_path, capsys):
    assert main(["train", "paper_map", "update.gama=1", "--logdir", str(tmp_path / "x")]) == 2
    assert "update.gama" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
    assert main(["train", "--logdir", str(tmp_path / "y")]) == 2
    assert "RECIPE" in capsys.readouterr().err
    assert main(["train", "--help-keys"]) == 0
    text = capsys.readouterr().out
    assert "update.gamma = 0.95" in text and "option_critic.critic" in text


def test_evaluate_command(checkpoint, tmp_path, capsys):
    code = main(["evaluate", str(checkpoint), "--start", "0,0.5,0", "--out", str(tmp_path)])
    assert code == 0 and (tmp_path / "evaluate.png").is_file()
    assert "greedy trial" in capsys.readouterr().out
    assert main(["evaluate", str(tmp_path / "missing.pt")]) == 2
    assert "no such file" in capsys.readouterr().err


def _fake_step(poses, done, expert=0, winner=0):
    """A [B] transition with what the TrialRecorder reads."""
    from tensordict import TensorDict

    b = len(poses)
    pose = torch.tensor([[x, y, 0.0] for x, y in poses], dtype=torch.float64)
    return TensorDict(
        {
            "true_pose": pose - 0.5,  # where the step started (read at a trial's first step)
            "shielded": torch.zeros(b, dtype=torch.bool),
            "expert": torch.full((b,), expert),
            "winner": torch.full((b,), winner),
            "next": TensorDict(
                {
                    "true_pose": pose,
                    "reward": torch.full((b, 1), -0.5),
                    "collision": torch.zeros(b, 1, dtype=torch.bool),
                    "reached_goal": torch.tensor([[d] for d in done]),
                    "done": torch.tensor([[d] for d in done]),
                },
                [b],
            ),
        },
        [b],
    )


def test_trial_recorder_keeps_a_long_trial_while_others_end():
    from symrl.train import TrialRecorder

    recorder = TrialRecorder(2)
    finished = []
    for k in range(700):  # robot 0: trials of 3 steps; robot 1: one trial of 700 steps
        done = [k % 3 == 2, k == 699]
        ended = recorder.step(_fake_step([(k, 0.0), (0.0, k)], done), torch.zeros(2))
        assert ended.tolist() == done
        for b in map(int, ended.nonzero()[0]):
            finished.append((b, recorder.finish(b)))
    long = [r for b, r in finished if b == 1]
    short = [r for b, r in finished if b == 0]
    assert len(long) == 1 and len(short) == 233
    assert long[0]["steps"] == 700 and len(long[0]["path"]) == 701
    assert long[0]["path"][0] == [-0.5, -0.5] and long[0]["path"][-1] == [0.0, 699.0]
    assert long[0]["total_reinforcement"] == pytest.approx(-350.0)
    last = short[-1]
    assert last["steps"] == 3 and last["path"][1:] == [[696.0, 0.0], [697.0, 0.0], [698.0, 0.0]]
    assert last["ghosts"] == [last["path"][0]]  # one acting neuron all along
