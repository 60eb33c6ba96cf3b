"""The registry of option sources: what a region's sub-goal options are made of
(``options.source``), each by name with the rung it needs and its table.

An option source is a function of what the robot is told (its :class:`Knowledge`, of the
recipe's rung and nothing more) to a :class:`SubgoalTable`: per region, in the order of
``knowledge.regions.names``, the points the reflex's goal following may steer at, the goal
first. Three are shipped (:mod:`symrl.knowledge.option_tables`): ``rules`` (rung
``regions``), ``passages`` (``passages``) and ``map`` (``map``). A source of your own is one
module that registers a function at import::

    @register_option_source("middles", rung="regions")
    def middles(knowledge: Knowledge) -> SubgoalTable: ...

and a recipe or override names it as ``options.source: my_pkg.my_module:middles``: the module is
imported when the config is validated (so a saved config finds it again), and the name is then
looked up here. A name registered already (a module imported first, a test) may be given bare.
The config refuses a source whose rung is above the recipe's; the walls are only ever had from
``knowledge.geometry(...)``, which names the rung when they are not told. An option labelled
:data:`ROUTE` follows the planner (``map`` only).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from symrl.knowledge.option_tables import ROUTE, map_options, passage_options, rule_options
from symrl.knowledge.rungs import RUNGS, Knowledge, Rung, rung_at_least
from symrl.knowledge.subgoals import SubgoalTable

__all__ = [
    "ROUTE",
    "OptionSource",
    "TableFn",
    "register_option_source",
    "option_source",
    "option_sources",
    "option_table",
]

TableFn = Callable[[Knowledge], SubgoalTable]
"""An option source's table: what the robot is told -> its options per region."""


@dataclass(frozen=True)
class OptionSource:
    """Option source ``name``: needs knowledge ``rung`` (or higher); ``table`` builds its
    options from the robot's :class:`Knowledge`."""

    name: str
    rung: Rung
    table: TableFn


_SOURCES: dict[str, OptionSource] = {}


def _origin(table: TableFn) -> tuple[str, str]:
    """Where ``table`` is defined: its file and qualified name (a module loaded twice, by its
    dotted name and by its path, defines the same function twice)."""
    code = getattr(table, "__code__", None)
    return (code.co_filename if code else repr(table), getattr(table, "__qualname__", ""))


def _add(source: OptionSource) -> None:
    """Enter ``source``; a name taken by another function is an error."""
    name, rung = source.name, source.rung
    if not isinstance(name, str) or not name or any(c in name for c in ": \t\n"):
        raise ValueError(f"option source name={name!r}: a non-empty word without ':' or spaces")
    if rung not in RUNGS:
        raise ValueError(f"option source {name!r}: rung={rung!r} unknown; the rungs are {RUNGS}")
    old = _SOURCES.get(name)
    if old is not None and (old.rung, _origin(old.table)) != (rung, _origin(source.table)):
        raise ValueError(
            f"option source {name!r} is registered already (rung {old.rung}, "
            f"{_origin(old.table)[1]} of {_origin(old.table)[0]}); choose another name"
        )
    _SOURCES[name] = source


def register_option_source(name: str, rung: Rung) -> Callable[[TableFn], TableFn]:
    """A decorator: the function it decorates is option source ``name``, which needs knowledge
    ``rung`` (returns the function unchanged). Registering the same function again (its module
    imported twice) is allowed; a name another function holds is an error."""

    def register(table: TableFn) -> TableFn:
        _add(OptionSource(name, rung, table))
        return table

    return register


def option_sources() -> Mapping[str, OptionSource]:
    """Every source registered so far, by name (a read-only view)."""
    return MappingProxyType(_SOURCES)


def option_source(name: str) -> OptionSource:
    """The source ``name``: a registered name, or ``module.path:NAME`` (the module is imported,
    and registers NAME, a function defined in it). An unknown one is a one-line error listing
    the known names."""
    if not isinstance(name, str):
        raise ValueError(f"an option source is named by a string, got {type(name).__name__}")
    module, colon, short = name.rpartition(":")
    if colon:
        if not module or not short:
            raise ValueError("a source of a module is written module.path:NAME")
        try:
            imported = importlib.import_module(module)
        except ModuleNotFoundError as err:
            raise ValueError(
                f"cannot import module {module!r} ({err}); it must be importable "
                f"(PYTHONPATH) to register option source {short!r}"
            ) from None
        found = _SOURCES.get(short)
        if found is None or module not in (
            getattr(found.table, "__module__", None),  # defined there, or the file imported
            imported.__name__ if _origin(found.table)[0] == imported.__file__ else None,
        ):
            raise ValueError(
                f"module {module!r} registers no option source {short!r} (registered: "
                f"{', '.join(sorted(_SOURCES))})"
            )
        return found
    if name not in _SOURCES:
        raise ValueError(
            f"unknown option source; the sources are {', '.join(sorted(_SOURCES))}, or "
            "module.path:NAME for a module of your own that registers NAME "
            "(docs/how-to/add-a-knowledge-source.md)"
        )
    return _SOURCES[name]


def option_table(knowledge: Knowledge, source: str) -> SubgoalTable:
    """The options a robot told ``knowledge`` chooses among per region, made by source
    ``source`` (``options.source``); a source needing more than the robot is told, or a table
    without a row of options for every region, is an error."""
    try:
        found = option_source(source)
    except ValueError as err:
        raise ValueError(f"options.source={source!r}: {err}") from None
    if not rung_at_least(knowledge.rung, found.rung):
        raise ValueError(
            f"options.source={source} needs knowledge={found.rung} or higher, but the robot is "
            f"told knowledge={knowledge.rung}"
        )
    table = found.table(knowledge)
    names = tuple(knowledge.regions.names)
    if tuple(table.region_names) != names or not bool(table.valid.any(dim=1).all()):
        raise ValueError(
            f"options.source={source}: its table must hold a row of one option or more for each "
            f"region, in the order {', '.join(names)}; got rows for "
            f"{', '.join(table.region_names)} with {table.counts.tolist()} options"
        )
    return table


_add(OptionSource("rules", "regions", rule_options))
_add(OptionSource("passages", "passages", passage_options))
_add(OptionSource("map", "map", map_options))
