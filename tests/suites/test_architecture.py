"""The package's architecture as tests: stages without cycles, rooms of readable size, every
stage documented, a public face that resolves, and the README's Python runs as written."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

import mirl

ROOT = Path(mirl.__file__).parent
README = ROOT.parents[1] / "README.md"
# A guideline, not a cap: a module whose code (its docstrings aside) is longer than this, or a
# function whose code (its docstring aside) is longer than that, needs a reason a reviewer
# accepts, written in LONG_ON_PURPOSE.
# A module holds one concept whatever its length; it is never split to meet a number.
MODULE_GUIDELINE = 700
FUNCTION_GUIDELINE = 100
LONG_ON_PURPOSE = {  # "path/in/package.py" or "path.py:function" -> the reason
    "learning/learn.py": "one concept, learn(): a method's models built from its row's sources "
    "(the tables of builders at its end) and the relabelling rounds that refine them",
    "learning/verdicts.py": "one concept, the fault verdict: its evidence (soft counts, "
    "clustered failures, the drift driven alone), the posterior over the features and the "
    "verdict drawn from it; each part is the verdict's and nothing else's",
    "learning/feature_solver.py": "one algorithm, the Eq. 4 solver: its maximum-entropy form "
    "(with the maximum-likelihood face it searches) and the paper's procedure share the pooling "
    "of counts, the result record and the report",
    "experiments/run_report.py:format_report": "one printed page, written line by line in the "
    "order it reads",
    "world/ros_maps.py:load_ros_map": "checks each field of a map_server YAML where it is read, "
    "in the order of the format, each refusal one line naming the field",
}
STAGES = ("mdp", "world", "observations", "simulation", "physics", "learning", "planning", "worlds",
          "experiments", "envs", "viz", "cli")  # fmt: skip


def _modules() -> list[Path]:
    return sorted(ROOT.rglob("*.py"))


def test_no_import_cycles_between_modules():
    graph = grimp.build_graph("mirl")
    modules = sorted(graph.modules)
    state: dict[str, int] = {}  # 1 visiting, 2 done

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph.find_modules_directly_imported_by(m)):
            if state.get(n) == 1:
                cycle = stack[stack.index(n) :] + [n] if n in stack else [m, n]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if n not in state:
                visit(n, stack + [n])
        state[m] = 2

    for m in modules:
        if m not in state:
            visit(m, [m])


def test_every_stage_is_a_documented_package():
    for stage in STAGES:
        path = ROOT / f"{stage}.py" if stage == "mdp" else ROOT / stage / "__init__.py"
        assert path.exists(), stage
        doc = ast.get_docstring(ast.parse(path.read_text()))
        assert doc and len(doc.split()) >= 15, f"{path}: needs a docstring saying what it holds"


def test_every_package_is_a_stage_and_a_layer():
    """A new stage is listed here and in import-linter's layers, or neither test sees it."""
    import tomllib

    packages = {p.parent.name for p in ROOT.glob("*/__init__.py")}
    assert sorted(set(STAGES) - {"mdp"}) == sorted(packages)
    config = tomllib.loads((ROOT.parents[1] / "pyproject.toml").read_text())
    (layers,) = [c["layers"] for c in config["tool"]["importlinter"]["contracts"] if "layers" in c]
    layered = {m.strip().removeprefix("mirl.") for layer in layers for m in layer.split("|")}
    assert set(STAGES) <= layered


def _docstring_lines(tree: ast.Module) -> int:
    """The lines of every docstring in a module (its own, its classes' and functions')."""
    total = 0
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            if ast.get_docstring(node) is not None:
                first = node.body[0]
                total += first.end_lineno - first.lineno + 1
    return total


def test_long_modules_and_functions_have_a_reason():
    for path in _modules():
        text = path.read_text()
        rel = path.relative_to(ROOT).as_posix()
        tree = ast.parse(text)
        n = text.count("\n") - _docstring_lines(tree)  # documentation does not lengthen code
        assert n <= MODULE_GUIDELINE or rel in LONG_ON_PURPOSE, f"{rel}: {n} lines, no reason"
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                first = node.body[0]  # a docstring documents; it does not lengthen the code
                doc = first.end_lineno - first.lineno + 1 if ast.get_docstring(node) else 0
                length = node.end_lineno - node.lineno + 1 - doc
                key = f"{rel}:{node.name}"
                assert length <= FUNCTION_GUIDELINE or key in LONG_ON_PURPOSE, (
                    f"{key} (line {node.lineno}): {length} lines, no reason"
                )


def test_no_string_comparison_with_a_method_or_world_name_outside_its_table():
    """What differs between methods or worlds is read from their tables' rows, never decided by
    comparing a name, so adding one is a row and not a hunt through the code."""
    from mirl.learning.methods import METHODS
    from mirl.worlds import WORLDS

    names = set(METHODS) | set(WORLDS)
    tables = {"learning/methods.py", "worlds/registry.py"}
    found = []
    for path in _modules():
        rel = path.relative_to(ROOT).as_posix()
        if rel in tables:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                for side in (node.left, *node.comparators):
                    consts = (
                        side.elts if isinstance(side, ast.Tuple | ast.List | ast.Set) else [side]
                    )
                    if any(isinstance(c, ast.Constant) and c.value in names for c in consts):
                        found.append(f"{rel}:{node.lineno}")
    assert found == []


# Comparisons with a table's name outside the table's module that are not switches on that
# table, or that other work removes; "path/in/package.py:name" -> the reason. A stale entry
# fails, so the list shrinks as they go.
NOT_A_SWITCH_ON_A_TABLE = {
    "cli/commands.py:auto": "the --compare flag's value, not an IRL gradient",
    "learning/motion_models.py:paper": "a motion model's ξ (the paper's), not the Eq. 4 solver",
    "physics/calibration.py:forward": "an action's name, not an IRL gradient",
    "world/motion.py:uniform": "Eq. 5's error model, not DBN-EM's initialisation",
    "learning/motion_models.py:uniform": "Eq. 5's error model, not DBN-EM's initialisation",
    "cli/flags.py:auto": "--step-seconds auto, the robots' pace, not an IRL gradient",
    "observations/discretise.py:auto": "step_seconds='auto', the robots' pace, not an IRL gradient",
}
# Tables declared where the command line reads them at start-up (a light module) whose rows are
# carried out by another module's code, the estimator's: that module may compare their names too.
CARRIED_OUT_BY = {
    "learning/options.py:IRL_OBJECTIVES": "learning/irl.py",
    "learning/options.py:IRL_OPTIMIZERS": "learning/irl.py",
    "learning/options.py:EM_INITS": "learning/dbn_em.py",
}


def _tables() -> dict[str, tuple[str, ...]]:
    """Every table of names (a module-level ``NAME = Registry(...)`` or
    ``Registry.of_choices(...)``), as "module path:NAME" -> its names."""
    import importlib

    out = {}
    for path in _modules():
        rel = path.relative_to(ROOT).as_posix()
        for node in ast.parse(path.read_text()).body:
            target = node.targets[0] if isinstance(node, ast.Assign) else None
            target = node.target if isinstance(node, ast.AnnAssign) else target
            call = getattr(node, "value", None)
            if not (isinstance(target, ast.Name) and isinstance(call, ast.Call)):
                continue
            made_by = call.func.value if isinstance(call.func, ast.Attribute) else call.func
            if isinstance(made_by, ast.Name) and made_by.id == "Registry":
                module = importlib.import_module("mirl." + rel[:-3].replace("/", "."))
                out[f"{rel}:{target.id}"] = tuple(getattr(module, target.id))
    return out


def _string_switches(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, string) of every switch on a string: ``x == "a"``, ``x != "a"``,
    ``x in ("a", "b")`` and ``case "a":``. (A literal looked up in data, ``"a" in row``,
    is not a switch.)"""
    out = []
    for node in ast.walk(tree):
        consts: list[ast.expr] = []
        if isinstance(node, ast.Compare):
            for op, right in zip(node.ops, node.comparators, strict=True):
                if isinstance(op, ast.Eq | ast.NotEq):
                    consts += [node.left, right]
                elif isinstance(op, ast.In | ast.NotIn) and isinstance(
                    right, ast.Tuple | ast.List | ast.Set
                ):
                    consts += right.elts
        elif isinstance(node, ast.MatchValue):
            consts = [node.value]
        out += [
            (node.lineno, c.value)
            for c in consts
            if isinstance(c, ast.Constant) and isinstance(c.value, str)
        ]
    return out


def test_string_switches_are_found():
    code = (
        'if self.mode == "pair": pass\n'
        'if "yaw" in header: pass\n'
        'if hazard not in ("markov", "independent"): pass\n'
        'match kind:\n    case "moved": pass\n'
    )
    assert _string_switches(ast.parse(code)) == [
        (1, "pair"), (3, "markov"), (3, "independent"), (5, "moved")
    ]


def test_tables_are_registries_found_by_the_string_switch_test():
    """The tables issue 38 names are found (so the next test reads them all)."""
    found = {key.split(":")[1] for key in _tables()}
    for table in ("METHODS", "FORMATS", "KINDS", "EXPERIMENTS", "SECTIONS", "GO_RULES",
                  "HAZARDS", "BELIEF_MODES", "IRL_OBJECTIVES", "IRL_OPTIMIZERS", "EM_INITS",
                  "REWARD_BUILDERS", "TRANSITION_BUILDERS", "FEATURE_SOLVERS", "LABELLINGS",
                  "WORLDS", "GRADIENTS", "ANCHORS"):  # fmt: skip
        assert table in found, table
    assert set(CARRIED_OUT_BY) <= set(_tables()), "stale entries"


def test_no_string_switch_on_a_table_outside_its_module():
    """What differs between the rows of a table (modes, hazards, formats, kinds, sources…) is
    the row's to say, not a comparison with its name somewhere else; so adding a row is the
    row. A table's own module may compare its names (its rows' checks, its estimator's
    choices)."""
    homes: dict[str, set[str]] = {}
    for key, names in _tables().items():
        for name in names:
            homes.setdefault(name, set()).add(key.split(":")[0])
            if key in CARRIED_OUT_BY:
                homes[name].add(CARRIED_OUT_BY[key])
    found, allowed_seen = [], set()
    for path in _modules():
        rel = path.relative_to(ROOT).as_posix()
        for line, value in _string_switches(ast.parse(path.read_text())):
            if value not in homes or rel in homes[value]:
                continue
            if f"{rel}:{value}" in NOT_A_SWITCH_ON_A_TABLE:
                allowed_seen.add(f"{rel}:{value}")
            else:
                found.append(f"{rel}:{line} compares with '{value}'")
    assert found == []
    assert sorted(set(NOT_A_SWITCH_ON_A_TABLE) - allowed_seen) == [], "stale entries"


def test_public_face_resolves_every_name():
    for name in mirl.__all__:
        assert getattr(mirl, name) is not None, name


def test_import_mirl_is_cheap():
    code = "import sys, mirl; print(sorted(m for m in ('numpy', 'scipy') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_readme_python_runs_as_written(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "the README has a Python example"
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        assert re.search(r"from mirl(\.envs)? import", block), "README examples use the public face"
        exec(compile(block, "README.md", "exec"), {})


def test_code_version_hashes_the_whole_package(tmp_path, monkeypatch):
    """A sweep row's fingerprint must change when any stage's source changes (learning,
    planning, ...), not only the experiments stage that computes it."""
    import shutil

    import mirl
    from mirl.experiments import conditions

    copy = tmp_path / "mirl"
    shutil.copytree(Path(mirl.__file__).parent, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(conditions, "__file__", str(copy / "experiments" / "conditions.py"))
    before = conditions.code_version.__wrapped__()
    (copy / "learning" / "irl.py").write_text((copy / "learning" / "irl.py").read_text() + "\n#")
    assert conditions.code_version.__wrapped__() != before
