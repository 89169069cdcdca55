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
MAX_MODULE_LINES = 900  # one algorithm, one module: folds of cap-driven splits reach ~800
MAX_FUNCTION_LINES = 120  # lines of code, the docstring not counted (numpydoc sections are long)
STAGES = ("mdp", "world", "observations", "simulation", "learning", "planning",
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


def test_modules_and_functions_fit_in_one_sitting():
    for path in _modules():
        text = path.read_text()
        n = text.count("\n")
        assert n <= MAX_MODULE_LINES, f"{path.relative_to(ROOT)}: {n} lines"
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                first = node.body[0]
                doc = first.end_lineno - first.lineno + 1 if ast.get_docstring(node) else 0
                length = node.end_lineno - node.lineno + 1 - doc
                assert length <= MAX_FUNCTION_LINES, (
                    f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {length} lines"
                )


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
