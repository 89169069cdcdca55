"""The one table type: lookup, known names, "did you mean", rows refused where they are
defined."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from mirl._registry import (
    Choice,
    Registry,
    UnknownNameError,
    check_entry_point,
    did_you_mean,
    resolve,
)


@dataclass(frozen=True)
class Row:
    name: str
    size: int = 1


def test_lookup_order_and_mapping_behaviour():
    table = Registry("thing", [Row("grid"), Row("physics", 2)])
    assert table.names == ("grid", "physics")
    assert list(table) == ["grid", "physics"] and len(table) == 2
    assert table["physics"].size == 2 and table.lookup("grid").size == 1
    assert "grid" in table and "mujoco" not in table
    assert table.get("mujoco") is None  # the Mapping contract holds
    assert dict(table.items())["grid"] == Row("grid")


def test_unknown_name_is_one_line_with_suggestions():
    table = Registry("world", [Row("grid"), Row("physics")])
    with pytest.raises(UnknownNameError) as e:
        table["phisics"]
    text = str(e.value)
    assert text == "unknown world 'phisics' (did you mean 'physics'? known: grid, physics)"
    assert isinstance(e.value, ValueError) and isinstance(e.value, KeyError)
    assert e.value.known == ("grid", "physics")
    with pytest.raises(UnknownNameError, match=r"^unknown world 'zzz' \(known: grid, physics\)$"):
        table.lookup("zzz")


def test_among_narrows_the_acceptable_names():
    table = Registry("method", [Row("mirl-t"), Row("random")])
    with pytest.raises(UnknownNameError, match=r"known: mirl-t\)$"):
        table.lookup("random", among=("mirl-t",))


def test_rows_are_checked_where_they_are_defined():
    def positive(row: Row) -> None:
        if row.size < 1:
            raise ValueError(f"row '{row.name}': size must be at least 1")

    with pytest.raises(ValueError, match="size must be at least 1"):
        Registry("thing", [Row("a"), Row("b", 0)], check=positive)
    with pytest.raises(ValueError, match="registered twice"):
        Registry("thing", [Row("a"), Row("a")])


def test_did_you_mean_prefers_the_closest_and_prefixes():
    assert did_you_mean("sead", ["seed", "steps", "scenario"]) == ["seed"]
    near = did_you_mean("obs", ["obs-steps", "observations", "seed"])
    assert near == ["obs-steps", "observations"]
    assert did_you_mean("xyz", ["seed"]) == []


def test_a_table_of_choices_is_names_and_what_they_mean():
    table = Registry.of_choices("hazard", {"markov": "first order", "independent": "naive"})
    assert table.names == ("markov", "independent")
    assert table["markov"] == Choice("markov", "first order")
    with pytest.raises(UnknownNameError, match="did you mean 'markov'"):
        table.lookup("markow")


def test_an_entry_point_names_a_module_and_an_attribute():
    import json

    assert resolve("json:dumps") is json.dumps
    check_entry_point("mirl.worlds.grid:GridRunWorld", "world 'grid': entry point")
    for bad in ("mirl.worlds.grid", "mirl.worlds.grid:", ":GridRunWorld", "mirl..grid:X",
                "mirl.worlds.grid:Grid World", None):  # fmt: skip
        with pytest.raises(ValueError, match=r"^go rule 'x': entry point .* is not 'package"):
            check_entry_point(bad, "go rule 'x': entry point")


def test_a_go_rule_whose_strategy_cannot_be_named_is_refused_with_its_table():
    from mirl.experiments.options import GO_RULES, GoRule

    with pytest.raises(ValueError, match="go rule 'late': entry point 'go_rules.Late'"):
        GO_RULES.register(GoRule("late", "goes late", "go_rules.Late"))
    assert "late" not in GO_RULES
