"""The knowledge boundary: an agent is built from what its recipe says it is told, and nothing
more. Below ``map`` it holds no walls and no free-space polygon, so two worlds that differ only
in their walls give the same agent."""

from __future__ import annotations

import pytest
import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.assembly import build_policy
from symrl.knowledge.rungs import RUNGS, Knowledge, rung_at_least
from symrl.learner.config import ConfigError, builtin_recipes, load_config
from symrl.train import make_env
from symrl.world.worldmap import load_map

# a box on the room's floor: the same region rules, start and goal, other walls
BOX = [[1.0, 1.0], [2.0, 1.0], [2.0, 1.8], [1.0, 1.8]]


def test_the_rungs_are_ordered():
    assert RUNGS == ("sensors", "regions", "passages", "map")
    assert rung_at_least("map", "passages") and rung_at_least("regions", "regions")
    assert not rung_at_least("sensors", "regions") and not rung_at_least("passages", "map")


def test_below_map_the_knowledge_holds_no_geometry():
    world = load_map("hailu2001")
    for rung in ("sensors", "regions", "passages"):
        told = Knowledge.told(world, rung)
        assert told.world is None
        assert (told.start, told.goal) == (world.start, world.goal)
        with pytest.raises(ValueError, match=f"localize needs knowledge=map .* knowledge={rung}"):
            told.geometry("localize")
    assert Knowledge.told(world, "regions").regions == world.regions
    assert Knowledge.told(world, "regions").passages is None
    # the passages rung: the door's stretch of l2 and l3 and the room | concave line, no walls
    doors = {
        (b.line, round(b.lo, 6), round(b.hi, 6))
        for b in Knowledge.told(world, "passages").passages or ()
    }
    assert doors == {("l1", -1.5, 3.5), ("l2", -1.0, 0.0), ("l3", -1.0, 0.0)}
    assert Knowledge.told(world, "sensors").regions.names == ("all",)
    assert Knowledge.told(world, "map").geometry("options") is world
    with pytest.raises(ValueError, match="knowledge='walls': unknown"):
        Knowledge.told(world, "walls")


@pytest.mark.parametrize(
    ("override", "needed"),
    [("options.enabled=true", "map"), ("localize.enabled=true", "map")],
)
def test_a_setting_above_the_declared_rung_is_a_one_line_error(override, needed):
    with pytest.raises(ConfigError) as err:
        load_config("paper_literal", [override])
    message = str(err.value)
    assert "\n" not in message
    assert override in message and f"needs knowledge={needed}" in message
    assert "knowledge=regions" in message
    with pytest.raises(ConfigError, match="gate.partition=true needs knowledge=regions"):
        load_config("paper_literal", ["knowledge=sensors"])
    # sub-goals from the rules need only the rules; the settings that read the walls need more
    assert load_config("paper_literal", ["options.enabled=true", "options.source=rules"])
    with pytest.raises(ConfigError, match=r"options.source=map \(with .*\) needs knowledge=map"):
        load_config("paper", ["options.source=map"])


def test_every_recipe_declares_a_rung_its_settings_fit():
    for recipe in builtin_recipes():
        config = load_config(recipe)
        assert config.knowledge in RUNGS
    assert load_config("paper").knowledge == "regions"
    assert load_config("paper_literal").knowledge == "regions"
    assert load_config("paper_map").knowledge == "map"
    assert load_config("paper_passages").knowledge == "passages"
    with pytest.raises(
        ConfigError, match=r"options.source=passages \(with .*\) needs knowledge=passages"
    ):
        load_config("paper", ["options.source=passages"])


def test_an_agent_is_refused_knowledge_of_another_rung_than_its_config():
    told = Knowledge.told(load_map("hailu2001"), "map")
    with pytest.raises(ValueError, match="knowledge=regions in the config"):
        build_policy(load_config("paper"), told)


def test_two_worlds_with_the_same_rules_give_the_same_agent_below_map():
    """``paper`` (regions) in the paper's world and in the same world with a box on the floor:
    the same knowledge, the same state, the same actions on the same observations. Told the map
    (``paper_map``), the box changes what the agent holds."""
    plain = load_map("hailu2001")
    boxed = plain.with_obstacle(BOX)
    config = load_config("paper")
    a = build_policy(config, plain, [3, 4])
    b = build_policy(config, boxed, [3, 4])
    assert a.knowledge.world is None and b.knowledge.world is None
    assert a.knowledge.regions == b.knowledge.regions
    state_a, state_b = a.state_dict(), b.state_dict()
    assert state_a.keys() == state_b.keys()
    assert all(torch.equal(state_a[k], state_b[k]) for k in state_a)
    env = make_env(config, [3, 4])
    td = env.reset()
    with set_exploration_type(ExplorationType.RANDOM):
        for _ in range(15):
            act_a = a(a.perception_transform()(td.clone()))["action"]
            act_b = b(b.perception_transform()(td.clone()))["action"]
            assert torch.equal(act_a, act_b)
            td = env.step(td.set("action", act_a))["next"]
    mapped = load_config("paper_map")
    assert build_policy(mapped, boxed).knowledge.world is boxed
