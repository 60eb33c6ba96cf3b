"""Option sources as a registry, and the how-to's worked example
(docs/how-to/add-a-knowledge-source.md): the page shows ``examples/border_middles.py`` as it
is, the registry knows the shipped sources, a source of a module of one's own makes the
options' table, the config refuses a source above the recipe's rung, and the example trains."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import torch

from symrl.assembly import build_policy
from symrl.knowledge.borders import border_subgoals
from symrl.knowledge.option_sources import (
    option_source,
    option_sources,
    option_table,
    register_option_source,
)
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import ConfigError, load_config
from symrl.world.worldmap import load_map

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "border_middles.py"
PAGE = ROOT / "docs" / "how-to" / "add-a-knowledge-source.md"
MIDDLES = "examples.border_middles:middles"

TOLD: list[Knowledge] = []
"""The knowledge each call of the test sources below was given."""


@register_option_source("test_goal_and_start", rung="regions")
def goal_and_start(knowledge: Knowledge) -> SubgoalTable:
    """Per region the goal, then the start."""
    TOLD.append(knowledge)
    goal = (float(knowledge.goal.x), float(knowledge.goal.y))
    start = (float(knowledge.start.x), float(knowledge.start.y))
    rows = [[(goal, "goal"), (start, "start")] for _ in knowledge.regions.names]
    return SubgoalTable.of(tuple(knowledge.regions.names), rows)


@register_option_source("test_walls", rung="map")
def walls(knowledge: Knowledge) -> SubgoalTable:
    """Needs the map: per region the goal and the world's lower left corner."""
    xmin, _, ymin, _ = knowledge.geometry("test_walls").bounds
    goal = (float(knowledge.goal.x), float(knowledge.goal.y))
    rows = [[(goal, "goal"), ((xmin, ymin), "corner")] for _ in knowledge.regions.names]
    return SubgoalTable.of(tuple(knowledge.regions.names), rows)


@register_option_source("test_walls_below_the_map", rung="regions")
def walls_below(knowledge: Knowledge) -> SubgoalTable:
    """Declares ``regions`` but asks for the walls."""
    return walls(knowledge)


def test_the_page_shows_the_example_file_as_it_is():
    page = PAGE.read_text()
    block = page.split("```python\n", 1)[1].split("```\n", 1)[0]
    assert block == EXAMPLE.read_text()


def test_the_registry_knows_the_shipped_sources_with_their_rungs():
    sources = option_sources()
    shipped = {name: sources[name].rung for name in ("rules", "passages", "map")}
    assert shipped == {"rules": "regions", "passages": "passages", "map": "map"}
    world = load_map("office")
    told = Knowledge.told(world, "passages")
    rules, doors = option_table(told, "rules"), option_table(told, "passages")
    assert rules.labels == border_subgoals(told.regions, told.goal).labels
    assert doors.labels == border_subgoals(told.regions, told.goal, told.passages).labels
    assert rules.labels != doors.labels
    with pytest.raises(TypeError):
        sources["mine"] = sources["rules"]  # type: ignore[index]


@register_option_source("test_one_region", rung="sensors")
def one_region(knowledge: Knowledge) -> SubgoalTable:
    """A row for one region only."""
    goal = (float(knowledge.goal.x), float(knowledge.goal.y))
    return SubgoalTable.of(("room",), [[(goal, "goal")]])


def test_a_table_without_a_row_for_every_region_is_refused():
    told = Knowledge.told(load_map("hailu2001"), "regions")
    with pytest.raises(ValueError, match="row of one option or more for each region, in the "):
        option_table(told, "test_one_region")


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        ("nope", r"unknown option source; the sources are .*map, .*passages, .*test_walls"),
        ("no_such_module:x", r"cannot import module 'no_such_module'"),
        ("os.path:rules", r"module 'os.path' registers no option source 'rules'"),
        (":rules", r"module.path:NAME"),
    ],
)
def test_a_bad_source_is_one_line_naming_the_key_and_the_value(value, reason):
    with pytest.raises(ConfigError) as err:
        load_config("paper", [f"options.source={value}"])
    message = str(err.value)
    assert "\n" not in message and message.startswith(f"options.source={value!r}: ")
    assert re.search(reason, message), message
    with pytest.raises(ValueError, match=f"options.source={value!r}: "):
        option_table(Knowledge.told(load_map("hailu2001"), "regions"), value)


def test_registering_keeps_one_function_per_name():
    register_option_source("test_goal_and_start", "regions")(goal_and_start)  # again: allowed
    with pytest.raises(ValueError, match="'rules' is registered already"):
        register_option_source("rules", "regions")(goal_and_start)
    with pytest.raises(ValueError, match="rung='roads' unknown"):
        register_option_source("test_roads", "roads")(goal_and_start)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="name='a:b'"):
        register_option_source("a:b", "regions")(goal_and_start)
    assert "test_roads" not in option_sources() and "a:b" not in option_sources()


def test_a_registered_source_makes_the_table_the_options_hold():
    """The policy's options choose among the source's table, and the source is given what a
    robot of the recipe's rung is told, nothing more."""
    world = load_map("hailu2001")
    config = load_config("paper", ["options.source=test_goal_and_start", "crossings.enabled=false"])
    TOLD.clear()
    policy = build_policy(config, world, [0, 1])
    assert [k.rung for k in TOLD] == ["regions"] and TOLD[0].world is None
    table = policy.subgoals
    assert table is not None
    assert table.labels == [["goal", "start"]] * len(world.regions.names)
    torch.testing.assert_close(table.points[0, 1], torch.tensor([world.start.x, world.start.y]))
    assert policy.options.points.shape == (len(world.regions.names), 2, 2)


def test_a_source_above_the_recipes_rung_is_refused():
    with pytest.raises(ConfigError) as err:
        load_config("paper", ["options.source=test_walls", "crossings.enabled=false"])
    assert "options.source=test_walls (with options.enabled=true) needs knowledge=map" in str(
        err.value
    )
    assert "declares knowledge=regions" in str(err.value)
    mapped = load_config("paper_map", ["options.source=test_walls"])
    assert build_policy(mapped).subgoals.labels[0] == ["goal", "corner"]  # type: ignore[union-attr]
    # a source that declares less than it asks for meets the knowledge boundary
    below = load_config(
        "paper", ["options.source=test_walls_below_the_map", "crossings.enabled=false"]
    )
    with pytest.raises(ValueError, match="test_walls needs knowledge=map .* knowledge=regions$"):
        build_policy(below)
    with pytest.raises(ValueError, match="options.source=test_walls needs knowledge=map or higher"):
        option_table(Knowledge.told(load_map("hailu2001"), "passages"), "test_walls")


def test_the_example_trains_and_moves_only_the_long_borders_options(monkeypatch):
    """``paper`` with the example's source: two robots train two trials; their options are
    the example's, which are ``rules``' options but for where a border runs on past the
    goal's level: the middle of it instead, on the same side of the same line."""
    from symrl.train import train_batch

    monkeypatch.syspath_prepend(str(ROOT))
    config = load_config(
        "paper", [f"options.source={MIDDLES}", "crossings.enabled=false", "run.trials=2"]
    )
    assert option_source(MIDDLES).rung == "regions"
    results = train_batch(config, [0, 1], progress=False)
    assert [[r["trial"] for r in res.trials] for res in results] == [[1, 2], [1, 2]]
    told = Knowledge.told(load_map("hailu2001"), "regions")
    mine, rules = option_table(told, MIDDLES), option_table(told, "rules")
    for res in results:
        assert res.policy.subgoals.labels == mine.labels
        torch.testing.assert_close(res.policy.subgoals.points, mine.points)
    assert mine.labels == rules.labels
    assert torch.equal(mine.valid, rules.valid) and torch.equal(
        mine.points[:, 0], rules.points[:, 0]
    )
    moved = {
        (mine.region_names[r], mine.labels[r][k])
        for r, k in zip(
            *torch.nonzero((mine.points != rules.points).any(-1)).T.tolist(), strict=True
        )
    }
    assert moved == {("room", "l1>concave"), ("room", "l2>door"), ("door", "l3>corridor")}
    for region, label in moved:  # the same line, the same side: only along the line
        r = mine.region_names.index(region)
        k = mine.labels[r].index(label)
        across = 0 if label.startswith(("l2", "l3")) else 1  # l2, l3: x = c; l1: y = c
        assert mine.points[r, k, across] == rules.points[r, k, across]


def test_the_example_loaded_by_its_path_and_by_its_module_is_one_source(monkeypatch):
    """A module imported twice (by its file, as a script does, and by its dotted name, as the
    config does) registers one source, found either way."""
    import importlib.util

    monkeypatch.syspath_prepend(str(ROOT))
    spec = importlib.util.spec_from_file_location("border_middles_by_path", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    by_path = option_source("middles")
    by_module = option_source(MIDDLES)
    assert by_module.rung == by_path.rung == "regions"
    assert by_module.table.__code__.co_filename == str(EXAMPLE)
    told = Knowledge.told(load_map("office"), "regions")
    assert option_table(told, "middles").labels == option_table(told, MIDDLES).labels
