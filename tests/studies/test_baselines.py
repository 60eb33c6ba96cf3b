"""The deep-RL baselines: the priors they are handed, their run folders, their checkpoints."""

from __future__ import annotations

import math

import pytest
import torch
from tensordict import TensorDict

from symrl.cli import main
from symrl.learner.config import load_config
from symrl.runs import BASE_COLUMNS, read_trials_csv
from symrl.studies.baseline import (
    first_reliable,
    load_baseline,
    make_env,
    parse_seeds,
    summarise,
    train_baseline,
)
from symrl.studies.priors import PriorAction, PriorObservation, Priors, observation_size
from symrl.world.worldmap import load_map

# tiny networks and budgets: these tests check the plumbing, not the learning
TINY = {
    "sac": [
        "baseline.sac.hidden=16",
        "baseline.sac.batch_size=16",
        "baseline.sac.learning_starts=20",
        "baseline.sac.buffer_size=1000",
    ],
    "ppo": [
        "baseline.ppo.hidden=16",
        "baseline.ppo.frames_per_batch=32",
        "baseline.ppo.minibatch=16",
        "baseline.ppo.epochs=1",
        "baseline.envs=2",
    ],
}


def tiny(algorithm, seed, trials, *extra):
    """The recipe ``algorithm`` with tiny networks, ``seed`` and ``trials``."""
    return load_config(
        algorithm, [*TINY[algorithm], f"run.seed={seed}", f"run.trials={trials}", *extra]
    )


@pytest.fixture(scope="module")
def config():
    return load_config("sac")


def _td(control, reflex=None, ir=None):
    b = len(control)
    data = {"control": torch.tensor(control, dtype=torch.float32).reshape(b, 1)}
    if reflex is not None:
        data["reflex_action"] = torch.tensor(reflex, dtype=torch.float32).reshape(b, 1)
        data["ir"] = torch.zeros(b, 24) if ir is None else ir
    return TensorDict(data, [b])


def test_residual_action_is_reflex_plus_correction(config):
    act = PriorAction(Priors(residual=True, correction=0.25), config)
    control, reflex = [-1.0, -0.5, 0.0, 0.3, 1.0], [0.4, -1.2, 0.0, 1.0, -0.2]
    td = act(_td(control, reflex))  # no wall within IR range: the shield keeps every action
    want = torch.tensor(
        [r + 0.25 * math.pi * u for u, r in zip(control, reflex, strict=True)], dtype=torch.float64
    )
    torch.testing.assert_close(td["action"].squeeze(-1).double(), want, atol=1e-6, rtol=0)
    assert not td["shielded"].any()


def test_correction_is_clipped_to_its_range(config):
    act = PriorAction(Priors(residual=True, correction=0.25), config)
    td = act(_td([3.0, -7.0], [0.0, 0.0]))  # a control outside [-1, 1] moves at most c * pi
    torch.testing.assert_close(td["action"].squeeze(-1), torch.tensor([0.25, -0.25]) * math.pi)
    td = act(_td([1.0, -1.0], [0.9 * math.pi, -0.9 * math.pi]))  # the sum stays in [-pi, pi]
    torch.testing.assert_close(td["action"].squeeze(-1), torch.tensor([math.pi, -math.pi]))


def test_residual_action_is_shielded(config):
    act = PriorAction(Priors(residual=True), config)
    ir = torch.zeros(1, 24)
    ir[0, 0] = 90.0  # a wall right ahead, closer than the margin
    td = act(_td([0.0], [0.0], ir))
    assert bool(td["shielded"][0]) and abs(float(td["action"][0, 0])) > 0.3


def test_scratch_action_is_pi_times_control(config):
    td = PriorAction(Priors(), config)(_td([-1.0, 0.5]))
    torch.testing.assert_close(td["action"].squeeze(-1), torch.tensor([-math.pi, 0.5 * math.pi]))
    assert not td["shielded"].any()


def test_priors_reject_a_correction_out_of_range():
    for bad in (0, -0.1, 1.5, True):
        with pytest.raises(ValueError, match="correction"):
            Priors(residual=True, correction=bad)


def test_region_one_hot_names_the_odometry_region(config):
    from symrl.knowledge.regions import RegionMapper

    world = load_map("hailu2001")
    transform = PriorObservation(Priors(regions=True), config, world)
    poses = torch.tensor([[0.0, 0.0, 0.0], [2.0, -0.35, 0.0], [4.5, 2.0, 0.0], [5.0, -3.5, 0.0]])
    td = TensorDict(
        {"sonar": torch.rand(4, 24), "goal": torch.tensor([[2.5, 0.5]] * 4), "odometry": poses}, [4]
    )
    obs = transform(td)["observation"]
    r = len(world.regions.names)
    assert obs.shape == (4, observation_size(Priors(regions=True), 24, r)) == (4, 26 + r)
    hot = obs[:, 26:]
    ids = RegionMapper.from_map(world)(poses)
    assert torch.equal(hot.argmax(-1), ids) and torch.equal(hot.sum(-1), torch.ones(4))
    assert len(set(ids.tolist())) > 1  # the poses span several regions
    torch.testing.assert_close(obs[:, 24], torch.full((4,), 2.5 / 5.0))
    torch.testing.assert_close(obs[:, 25], torch.full((4,), 0.5 / math.pi))


def test_residual_observation_carries_the_reflex_action(config):
    from symrl.knowledge.reflex import FuzzyReflex

    world = load_map("hailu2001")
    td = TensorDict(
        {
            "sonar": torch.rand(3, 24),
            "goal": torch.tensor([[2.0, 1.0]] * 3),
            "odometry": torch.zeros(3, 3),
        },
        [3],
    )
    out = PriorObservation(Priors(residual=True), config, world)(td)
    want = FuzzyReflex(config.reflex)(td["sonar"].double(), torch.ones(3, dtype=torch.float64))
    want = want.float().double()
    torch.testing.assert_close(out["reflex_action"].squeeze(-1).double(), want, atol=1e-6, rtol=0)
    torch.testing.assert_close(out["observation"][:, -1], out["reflex_action"][:, 0] / math.pi)


def test_the_env_passes_torchrl_spec_checks(config):
    from torchrl.envs.utils import check_env_specs

    told = load_config(
        "sac", ["baseline.residual=true", "baseline.regions=true", "knowledge=regions"]
    )
    env = make_env(told, [0, 1])
    check_env_specs(env, seed=0)
    td = env.reset()
    assert td["observation"].shape == (2, env.observation_spec["observation"].shape[-1])
    env.close()


def test_first_reliable_is_the_window_start():
    assert first_reliable([False] * 30) is None
    reached = [False] * 10 + [True] * 16 + [False] * 4
    # trials 7..26 hold 16 successes (80 %) for the first time
    assert first_reliable(reached, window=20, level=0.8) == 7
    assert first_reliable([True] * 20) == 1
    assert first_reliable([True] * 5) is None


def test_summarise_counts_the_budget_only():
    rows = [{"steps": 200, "total_reinforcement": -100.0, "collisions": 2, "reached_goal": False}]
    rows += [{"steps": 30, "total_reinforcement": -10.0, "collisions": 0, "reached_goal": True}]
    s = summarise(rows * 15, 20)
    assert s["trials"] == 20 and s["first_success"] == 2 and s["successes"] == 10
    assert s["collisions"] == 20 and s["env_steps"] == 10 * 230
    assert s["last5_actions"] == (3 * 30 + 2 * 200) / 5


def test_parse_seeds():
    assert parse_seeds("100-104") == [100, 101, 102, 103, 104]
    assert parse_seeds("100,105") == [100, 105]
    for bad in ("", "x", "5-2", "-3"):
        with pytest.raises(ValueError, match="--seeds"):
            parse_seeds(bad)


@pytest.mark.parametrize("algorithm", ["sac", "ppo"])
def test_a_tiny_baseline_writes_a_symrl_run_folder(algorithm, tmp_path, capsys):
    priors = Priors(residual=True, regions=True)
    told = ["baseline.residual=true", "baseline.regions=true", "knowledge=regions"]
    run = tmp_path / "run"
    result = train_baseline(tiny(algorithm, 3, 2, *told), run, progress=False)
    assert {"config.yaml", "trials.csv", "tb", "checkpoint.pt"} <= {p.name for p in run.iterdir()}
    rows = read_trials_csv(run / "trials.csv")
    assert len(rows) == 2 and "neurons" not in rows[0]  # the paper learner's columns stay empty
    header = (run / "trials.csv").read_text().splitlines()[0].split(",")
    assert header == list(BASE_COLUMNS)
    assert [r["trial"] for r in rows] == [1, 2]
    assert [r["steps"] for r in rows] == [r["steps"] for r in result.trials]
    assert result.timings["frames"] >= sum(r["steps"] for r in rows)
    assert any(p.name.startswith("events") for p in (run / "tb").rglob("*"))
    controller = load_baseline(run / "checkpoint.pt")
    assert controller is not None and controller.priors == priors
    (record,) = controller.evaluate(seed=0)
    assert record["steps"] >= 1 and isinstance(record["reached_goal"], bool)
    assert main(["evaluate", str(run / "checkpoint.pt")]) == 0
    assert "greedy trial from (0, 0, 0 deg)" in capsys.readouterr().out
    assert (run / "evaluate.png").is_file()


def test_tensorboard_gets_the_trial_scalars(tmp_path):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    train_baseline(tiny("ppo", 1, 2, "baseline.residual=true"), tmp_path, progress=False)
    events = EventAccumulator(str(tmp_path / "tb"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert {
        "trial/steps",
        "trial/total_reinforcement",
        "trial/reached_goal",
        "trial/collisions",
    } <= tags
    assert not any(t.startswith("network/") for t in tags)


@pytest.mark.parametrize("algorithm", ["sac", "ppo"])
def test_a_run_is_deterministic_and_a_prefix_of_a_longer_one(algorithm):
    def rows(n):
        out = train_baseline(tiny(algorithm, 5, n, "baseline.residual=true"), progress=False)
        return [(r["steps"], r["total_reinforcement"], r["collisions"]) for r in out.trials]

    assert rows(3)[:2] == rows(2)  # same seed, same trials; the budget changes nothing before


def test_a_paper_checkpoint_is_not_a_baseline(tmp_path):
    from symrl.runs import save_checkpoint
    from symrl.train import train

    config = load_config("paper_map", ["run.trials=1"])
    result = train(config)
    save_checkpoint(tmp_path / "c.pt", result.policy, config, 0)
    assert load_baseline(tmp_path / "c.pt") is None
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    assert load_baseline(tmp_path / "junk.pt") is None


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--episodes", "0"], "--episodes 0"),
        (["--seeds", "a,b"], "--seeds"),
        (["--residual", "--correction", "1.5"], "baseline.correction=1.5"),
        (["--correction", "0.1"], "only with baseline.residual=true"),
        (["--envs", "0"], "baseline.envs=0"),
        (["--workers", "0"], "--workers 0"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    assert main(["baseline", "sac", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err


def test_an_unknown_algorithm_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["baseline", "dqn"])
    assert stop.value.code == 2 and len(capsys.readouterr().err.strip().splitlines()) == 1


def test_a_run_folder_is_never_overwritten_silently(tmp_path, capsys):
    argv = [
        "baseline",
        "ppo",
        "--episodes",
        "1",
        "--seeds",
        "0",
        "--residual",
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(argv) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_the_report_compares_every_learner_it_finds(tmp_path):
    from symrl.studies.report import baseline_table

    config = tiny("ppo", 2, 3, "baseline.residual=true")
    train_baseline(config, tmp_path / "ppo-residual" / "seed-2", progress=False)
    table, curves = baseline_table(tmp_path)
    row = next(line for line in table.splitlines() if line.startswith("| PPO residual |"))
    assert "| 3 | 1 |" in row  # 3 trials, 1 seed
    assert "| SAC residual | *not run*" in table and list(curves) == ["PPO residual"]
    assert len(curves["PPO residual"][0]) == 3


@pytest.mark.parametrize("algorithm", ["sac", "ppo"])
def test_a_resumed_run_is_the_uninterrupted_run(algorithm, tmp_path):
    from symrl.studies.learners import load_run

    def config(trials):
        return tiny(algorithm, 4, trials, "baseline.residual=true")

    train_baseline(config(4), tmp_path / "whole", progress=False)
    # stopped from outside in the middle of a trial (and, for PPO, of a batch), then resumed
    calls = iter(range(10_000))
    stopped = train_baseline(
        config(4), tmp_path / "parts", progress=False, stop=lambda: next(calls) >= 37
    )
    assert stopped.timings["stopped"] and len(stopped.trials) < 4
    # a stopped run goes on to a budget one trial larger, then that finished run to 4
    for trials in (len(stopped.trials) + 1, 4):
        saved, seed, state, world = load_run(tmp_path / "parts")
        assert seed == 4 and saved.baseline == config(4).baseline
        train_baseline(
            config(trials), tmp_path / "parts", world=world, resume=state, progress=False
        )
    whole = (tmp_path / "whole" / "trials.csv").read_text()
    assert (tmp_path / "parts" / "trials.csv").read_text() == whole
    assert len(whole.splitlines()) == 5


def test_train_resume_of_a_baseline_recipe_is_the_uninterrupted_run(tmp_path, capsys):
    argv = ["train", "ppo", "--seed", "3", *TINY["ppo"], "baseline.residual=true"]
    assert main([*argv, "--trials", "3", "--logdir", str(tmp_path / "whole")]) == 0
    assert main([*argv, "--trials", "1", "--logdir", str(tmp_path / "parts")]) == 0
    assert main(["train", "--resume", str(tmp_path / "parts"), "--trials", "2"]) == 0
    assert main(["train", "--resume", str(tmp_path / "parts"), "--trials", "3"]) == 0
    whole = (tmp_path / "whole" / "trials.csv").read_bytes()
    assert (tmp_path / "parts" / "trials.csv").read_bytes() == whole
    assert len(whole.splitlines()) == 4
    capsys.readouterr()
    # a checkpoint that is not the folder's run (config.yaml says another hidden size)
    recorded = tmp_path / "parts" / "config.yaml"
    recorded.write_text(recorded.read_text().replace("hidden: 16", "hidden: 64"))
    assert main(["train", "--resume", str(tmp_path / "parts"), "--trials", "4"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "baseline.ppo.hidden" in err, err


def test_periodic_checkpoints_hold_the_run_state(tmp_path):
    train_baseline(
        tiny("ppo", 6, 3, "baseline.residual=true"), tmp_path, progress=False, checkpoint_every=1
    )
    state = torch.load(tmp_path / "checkpoint.pt", weights_only=True)["resume"]
    assert [r["trial"] for r in state["trials"]] == [1, 2, 3]
    assert state["frames"] == sum(r["steps"] for r in state["trials"]) + int(
        state["recorder"]["steps"].sum()
    )  # the robots still in a trial are part of the state


def test_resume_from_the_command_line(tmp_path, capsys):
    argv = ["baseline", "ppo", "--seeds", "0", "--residual", "--out", str(tmp_path)]
    assert main([*argv, "--episodes", "1"]) == 0
    assert main([*argv, "--episodes", "2", "--resume"]) == 0
    assert len(read_trials_csv(tmp_path / "seed-0" / "trials.csv")) == 2
    capsys.readouterr()
    for extra, message in (
        (["--episodes", "2", "--resume", "--regions"], "the run has baseline.regions False"),
        (["--episodes", "1", "--resume"], "has done 2 trials already"),
        (["--episodes", "3", "--resume", "--overwrite"], "give one"),
    ):
        assert main([*argv, *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
    (tmp_path / "seed-0" / "checkpoint.pt").write_bytes(b"cut short")
    assert main([*argv, "--episodes", "3", "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a readable symrl checkpoint" in err
    assert len(read_trials_csv(tmp_path / "seed-0" / "trials.csv")) == 2  # nothing lost


def test_the_sac_checkpoint_holds_only_the_transitions_collected(tmp_path):
    train_baseline(tiny("sac", 2, 1, "baseline.residual=true"), tmp_path, progress=False)
    state = torch.load(tmp_path / "checkpoint.pt", weights_only=True)["resume"]
    buffer = state["agent"]["buffer"]
    assert buffer["observation"].shape[0] == state["frames"] == state["trials"][0]["steps"]
    assert buffer["observation"].untyped_storage().nbytes() == buffer["observation"].nbytes


def test_the_report_shows_a_long_run_in_blocks(tmp_path):
    from symrl.runs import write_trials_csv
    from symrl.studies.report import baseline_blocks

    for seed, late in ((0, 30), (1, 34)):
        rows = [
            {
                "trial": t + 1,
                "steps": 50 if t < 100 else late,
                "reached_goal": True,
                "total_reinforcement": -20.0 if t < 100 else -10.0,
                "collisions": 0,
            }
            for t in range(200 + 100 * seed)
        ]
        (tmp_path / "sac-residual" / f"seed-{seed}").mkdir(parents=True)
        write_trials_csv(tmp_path / "sac-residual" / f"seed-{seed}" / "trials.csv", rows)
    lines = baseline_blocks(tmp_path).splitlines()
    assert lines[2:] == [
        "| SAC residual | 1-100 | 2 | 50.0 ± 0.0 | -20.00 ± 0.00 |",
        "| SAC residual | 101-200 | 2 | 32.0 ± 2.8 | -10.00 ± 0.00 |",
        "| SAC residual | 201-300 | 1 | 34.0 ± 0.0 | -10.00 ± 0.00 |",
    ]
    assert baseline_blocks(tmp_path, least=400) == ""
