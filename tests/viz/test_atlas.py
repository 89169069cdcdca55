"""The calibration atlas's report section (mirl.viz.atlas), on hand-made stored runs."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.experiments.conditions import Condition
from mirl.viz.aggregate import Group
from mirl.viz.atlas import atlas_items, atlas_markdown, measures
from mirl.viz.verdicts import VerdictItem, expected_calibration_error


def _row(run: int, verdicts: dict[str, dict[str, tuple[str, float, int]]], truth: dict) -> dict:
    """A stored run: per data path, per robot (named parts, confidence, right)."""
    row: dict = {"run": run, "outcome": "learned"}
    for robot, parts in truth.items():
        row[f"truth.{robot}"] = parts
        row[f"seen.{robot}"] = 40
    for path, by_robot in verdicts.items():
        for robot, (named, conf, right) in by_robot.items():
            row[f"verdict.{path}.{robot}"] = named
            row[f"confidence.{path}.{robot}"] = conf
            row[f"right.{path}.{robot}"] = right
    row["command.simulate"] = "mirl simulate …"
    row["time.simulate"] = 2.0
    row["time.learn.grid-csv"] = 1.0
    return row


@pytest.fixture
def groups() -> list[Group]:
    damaged = Condition("mirl-t", "boyd2-healthy", 1.0, 450, world="physics",
                        damage="J:left_wheel=0.6")  # fmt: skip
    healthy = Condition("mirl-t", "boydright", 0.14, 150, world="grid", damage="none")
    truth = {"I": "", "J": "left_wheel"}
    return [
        Group(
            damaged,
            [
                _row(0, {
                    "grid-csv": {"I": ("", 0.99, 1), "J": ("navigation,floor", 0.97, 0)},
                    "pose-csv": {"I": ("", 0.98, 1), "J": ("left_wheel", 0.96, 1)},
                    "mcap": {"I": ("", 0.98, 1), "J": ("left_wheel", 0.96, 1)},
                }, truth),
                _row(1, {
                    "grid-csv": {"I": ("right_wheel", 0.92, 0), "J": ("", 0.95, 0)},
                    "pose-csv": {"I": ("", 0.7, 1), "J": ("left_wheel,navigation", 0.8, 1)},
                    # the MCAP path was refused: no verdicts from it
                }, truth),
            ],  # fmt: skip
        ),
        Group(healthy, [_row(0, {"grid-csv": {"I": ("", 0.6, 1), "J": ("", 0.97, 1)}},
                             {"I": "", "J": ""})]),  # fmt: skip
    ]


def test_the_items_are_every_stored_verdict_with_its_axes(groups):
    items = atlas_items(groups)
    assert len(items) == 6 + 4 + 2
    j0 = next(a for a in items if a.base.run == 0 and a.path == "grid-csv" and a.base.robot == "J"
              and a.base.world == "physics")  # fmt: skip
    assert j0.base.verdict == ("navigation", "floor") and j0.base.truth == ("left_wheel",)
    assert (j0.kind, j0.strength, j0.scenario) == ("one wheel", 0.6, "boyd2-healthy")
    assert j0.length == 450
    healthy = [a for a in items if a.base.world == "grid"]
    assert {(a.kind, a.strength) for a in healthy} == {("none", None)}


def test_the_measures_count_as_the_issue_defines_a_false_statement(groups):
    items = atlas_items(groups)
    m = measures(items)
    # confidently false: J "navigation, floor" (0.97), I "right wheel" (0.92) and a confident
    # "no part" of the damaged J (0.95); not the 0.8 candidates, which are right
    assert (m.n, m.false) == (12, 3)
    assert m.damaged == 5 and m.alone == 2 and m.among == 1
    assert m.healthy == 7 and m.healthy_ok == 6
    assert m.checked == 0 and m.misfit == 0
    bases = [a.base for a in items]
    assert m.ece == pytest.approx(expected_calibration_error(bases))
    # the same by hand: bins [0.5, 0.6): none; [0.6, 0.7): 0.6 right; [0.7, 0.8): 0.7 right;
    # [0.8, 0.9): 0.8 right; [0.9, 0.95): 0.92 wrong; [0.95, 0.99): 0.97 0.98 0.96 0.98 0.96
    # 0.95 0.97 (5 right of 7); [0.99, 1]: 0.99 right
    top = (0.97 + 0.98 + 0.96 + 0.98 + 0.96 + 0.95 + 0.97) / 7
    bins = [(1, 0.6, 1), (1, 0.7, 1), (1, 0.8, 1), (1, 0.92, 0), (7, top, 5 / 7), (1, 0.99, 1)]
    assert m.ece == pytest.approx(sum(n * abs(acc - c) for n, c, acc in bins) / 12)


def test_a_model_check_is_counted_where_the_verdict_has_one(groups):
    groups[0].rows[0]["fit.pose-csv.J"] = "ok"
    groups[0].rows[0]["fit.pose-csv.I"] = "moves longer than a cell"
    m = measures(atlas_items(groups))
    assert (m.checked, m.misfit) == (2, 1)


def test_the_section_flags_missed_targets_and_lists_what_reproduces_them(groups, tmp_path):
    md = atlas_markdown(groups, tmp_path)
    assert (tmp_path / "atlas.png").exists()
    assert "12 verdicts from 3 runs of 2 design points" in md
    assert "| confidently false ≤ 2% overall | **0.250 (3/12)** |" in md
    # the full-view row at 0.6 in physics: the grid CSV names J's wheel in 1 of 2 runs
    assert "full view, strength ≤ 0.6 or 0.7, physics, grid CSV" in md
    assert "**0.000 (0/2)**" in md
    assert "| data path | pose CSV | 4 |" in md
    assert "`mirl simulate …` then" in md
    assert "said **navigation or floor** at 0.970" in md


def test_confident_false_counts_a_confident_no_part_of_a_damaged_robot():
    def item(verdict, conf, truth, right):
        return VerdictItem("grid", 1.0, None, "J", 0, verdict, conf, truth, right)

    assert item((), 0.95, ("left_wheel",), False).confident_false
    assert not item((), 0.95, ("left_wheel",), False).confident_wrong
    assert item(("floor",), 0.9, ("left_wheel",), False).confident_false
    assert not item(("floor",), 0.89, ("left_wheel",), False).confident_false
    assert not item(("left_wheel",), 0.99, ("left_wheel",), True).confident_false


def test_the_cost_estimate_fits_each_world_and_scenario_linear_in_the_length():
    from mirl.viz.atlas import estimate_cpu

    def group(world, scenario, steps, cpus, robots=("I", "J")):
        c = Condition("mirl-t", scenario, 1.0, steps, world=world, damage="none")
        rows = [{"run": k, "time.simulate": t, **{f"truth.{r}": "" for r in robots}}
                for k, t in enumerate(cpus)]  # fmt: skip
        return Group(c, rows)

    gs = [group("grid", "boydright", 150, [3.0, 5.0]), group("grid", "boydright", 450, [10.0]),
          group("grid", "office", 150, [6.0], robots="IJKM")]  # fmt: skip
    # boydright: least squares through (150, 3), (150, 5), (450, 10): 1 + 0.02 n; the office,
    # one length, the line through its mean with the grid's slope per robot and step (fitted
    # to robot-steps and CPU of every grid run) times its 4 robots
    design = [Condition("mirl-t", "boydright", 0.14, 900, world="grid", damage="none"),
              Condition("mirl-t", "office", 1.0, 900, world="grid", damage="none")]  # fmt: skip
    px, py = [300, 300, 900, 600], [3.0, 5.0, 10.0, 6.0]
    per_robot_step = np.polyfit(px, py, 1)[0]
    office = 6.0 + 4 * per_robot_step * (900 - 150)
    assert estimate_cpu(gs, design) == pytest.approx(1 + 0.02 * 900 + office)
    other = Condition("mirl-t", "boyd2-healthy", 1.0, 150, world="physics", damage="none")
    assert estimate_cpu(gs, [*design, other]) is None


@pytest.mark.parametrize(
    ("verdict", "truth", "alone", "among"),
    [
        (("left_wheel",), ("left_wheel",), True, False),
        (("left_wheel", "right_wheel"), ("left_wheel", "right_wheel"), True, False),
        (("left_wheel",), ("left_wheel", "right_wheel"), True, False),
        (("left_wheel", "navigation"), ("left_wheel",), False, True),
        (("left_wheel", "right_wheel"), ("left_wheel",), False, True),
        (("navigation", "floor"), ("left_wheel", "right_wheel"), False, False),
        ((), ("left_wheel",), False, False),
    ],
)
def test_named_alone_means_only_damaged_parts_are_named(verdict, truth, alone, among):
    from mirl.viz.atlas import AtlasVerdict

    base = VerdictItem("grid", 1.0, "J:left_wheel", "J", 0, verdict, 0.95, truth, True)
    item = AtlasVerdict(base, "pose-csv", "boyd2-healthy", 450, "two wheels", 0.7, "ok", 450,
                        ("", ""))  # fmt: skip
    assert (item.named_alone, item.named_among) == (alone, among)


def test_a_part_said_damaged_besides_the_verdict_is_a_statement_of_its_own():
    """A healthy part the verdict says is damaged too, at 0.9 or more, is a confidently false
    statement even where the part it names is right; below 0.9, or damaged, it is not."""
    from mirl.viz.atlas import AtlasVerdict, measures

    def item(also, truth=("left_wheel",)):
        base = VerdictItem("physics", 1.0, "J:left_wheel", "J", 0, ("left_wheel",), 0.99, truth,
                           True, also)  # fmt: skip
        return AtlasVerdict(base, "pose-csv", "boyd2-healthy", 450, "one wheel", 0.6, "ok", 450,
                            ("", ""))  # fmt: skip

    assert item((("navigation", 0.95),)).base.confident_false
    assert not item((("navigation", 0.62),)).base.confident_false
    assert not item((("right_wheel", 0.98),), ("left_wheel", "right_wheel")).base.confident_false
    assert item(()).named_alone and item((("navigation", 0.62),)).named_alone
    m = measures([item((("navigation", 0.95),)), item((("navigation", 0.62),))])
    assert (m.false, m.alone) == (1, 2)


def test_a_stored_also_field_reads_back_as_parts_and_probabilities():
    from mirl.learning.verdicts import Verdict, also_field, parse_also_field

    assert parse_also_field(None) == () and parse_also_field("") == ()
    v = Verdict("left_wheel", 1.0, (), {"left_wheel": 1.0, "navigation": 0.622, "floor": 0.51})
    assert also_field(v) == "navigation=0.622,floor=0.51"
    assert parse_also_field(also_field(v)) == (("navigation", 0.622), ("floor", 0.51))


def test_a_robot_never_seen_moving_is_no_verdict_and_left_out_of_the_calibration(
    groups, tmp_path
):
    from mirl.learning.verdicts import NEVER_SEEN

    before = measures(atlas_items(groups))
    # the healthy run's I, never seen moving: "no part" at the prior's 0.6, right
    groups[1].rows[0]["fit.grid-csv.I"] = NEVER_SEEN
    items = atlas_items(groups)
    m = measures(items)
    assert (m.n, m.unseen) == (before.n - 1, 1)
    assert m.ece == pytest.approx(
        expected_calibration_error([a.base for a in items if a.base.confidence != 0.6])
    )
    assert m.ece != pytest.approx(before.ece)
    # still a healthy robot: its row counts it, and no statement of it is false
    assert (m.healthy, m.healthy_ok) == (before.healthy, before.healthy_ok)
    md = atlas_markdown(groups, tmp_path)
    assert "11 verdicts from 3 runs" in md and "(1 robot-paths)" in md
