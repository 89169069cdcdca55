"""Start-up stays at the floor: building the parser and light sub-commands import no learner,
no planner, no optimiser, no game solver and no plotting library."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("scipy.optimize", "nashpy", "networkx", "matplotlib", "joblib", "dask", "scipy.ndimage")

_PROBE = """
import json, sys
from mirl.cli import main
try:
    main({argv!r})
except SystemExit:
    pass
print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in
      ('numpy', 'scipy', 'nashpy', 'networkx', 'matplotlib', 'joblib', 'dask', 'mirl'))))
"""
# the modules of those stages the parser reads: the tables and the option types (all light)
TABLES = {
    "mirl.learning",
    "mirl.learning.methods",
    "mirl.learning.options",
    "mirl.experiments",
    "mirl.worlds",
    "mirl.worlds.contract",
    "mirl.worlds.registry",
    "mirl.experiments.options",
}


def _modules_after(argv: list[str]) -> set[str]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(argv=argv)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


@pytest.mark.parametrize("argv", [["--version"], ["show-map", "boyd2"]])
def test_light_commands_import_nothing_heavy(argv):
    loaded = _modules_after(argv)
    heavy = sorted(m for m in loaded if any(m == h or m.startswith(h + ".") for h in HEAVY))
    assert heavy == [], heavy
    # the parser reads the tables and the option types, and nothing else of those stages
    stages = ("mirl.learning", "mirl.planning", "mirl.worlds", "mirl.experiments")
    assert not any(m.startswith(stages) for m in loaded - TABLES), sorted(loaded - TABLES)


@pytest.mark.parametrize("argv", [["--version"], ["run", "--help"], ["learn", "--help"]])
def test_building_the_parser_imports_no_numpy(argv):
    """The flags are built from the option types and tables, which import nothing heavy."""
    loaded = _modules_after(argv)
    assert not any(m.split(".")[0] in ("numpy", "scipy") for m in loaded), sorted(loaded)


def test_import_mirl_imports_no_numpy():
    code = "import sys, mirl; print(sorted({m.split('.')[0] for m in sys.modules} & {'numpy'}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_a_run_on_a_shipped_scenario_imports_no_game_solver_or_plotting():
    """Learning weighs the game's equilibria; a shipped scenario's are stored, so `mirl run`
    needs neither nashpy (nor its networkx) nor, without --plot, matplotlib."""
    loaded = _modules_after(["run", "--obs-steps", "100", "--seed", "1", "--json"])
    assert "mirl.learning.equilibria" in loaded  # the run did weigh equilibria
    unwanted = ("nashpy", "networkx", "matplotlib", "joblib", "dask", "scipy.ndimage")
    heavy = sorted(m for m in loaded if any(m == h or m.startswith(h + ".") for h in unwanted))
    assert heavy == [], heavy


def test_loading_a_scenario_does_not_enumerate_equilibria():
    code = (
        "import sys; from mirl.world.scenario import load_scenario; "
        "s = load_scenario('boyd2'); s.played_equilibrium; print('nashpy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_the_vocabularies_have_one_home():
    """The learner's names are the options' own objects, not copies of them."""
    from mirl.learning import dbn_em, irl, options

    assert irl.OBJECTIVES is options.IRL_OBJECTIVES
    assert irl.OPTIMIZERS is options.IRL_OPTIMIZERS
    assert dbn_em.EM_INITS is options.EM_INITS


def test_pure_equilibrium_by_best_response_is_the_enumerated_one():
    from mirl.world.game import GAME_ACTIONS, InteractionGame

    game = InteractionGame()
    enumerated = [e for e in game.equilibria() if e.is_pure]
    found = []
    for a in GAME_ACTIONS:
        for b in GAME_ACTIONS:
            try:
                found.append(game.pure(a, b))
            except ValueError:
                pass
    assert sorted(found, key=lambda e: (e.row, e.col)) == sorted(
        enumerated, key=lambda e: (e.row, e.col)
    )
    assert len(found) >= 2


def test_cli_limits_blas_threads_before_numpy_loads():
    code = (
        "import os, sys\n"
        "for v in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS', "
        "'BLIS_NUM_THREADS'): os.environ.pop(v, None)\n"
        "from mirl.cli import main\n"
        "try:\n    main(['--version'])\nexcept SystemExit:\n    pass\n"
        "import numpy, scipy.linalg\n"
        "from threadpoolctl import threadpool_info\n"
        "print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "1"



def test_learning_with_a_team_comparison_imports_no_scipy_stats(tmp_path):
    """The team comparison's Beta quantiles come from scipy.special: importing scipy.stats
    would cost a `mirl learn` on boyd2 about a third of its time."""
    csv = tmp_path / "obs.csv"
    subprocess.run(
        [sys.executable, "-m", "mirl", "simulate", "--scenario", "boyd2", "--steps", "450",
         "--seed", "1", "--observations", str(csv)],
        capture_output=True, check=True,
    )  # fmt: skip
    argv = ["learn", "--scenario", "boyd2", "--observations", str(csv), "--json"]
    out = subprocess.run(
        [sys.executable, "-m", "mirl", *argv], capture_output=True, text=True, check=True
    ).stdout
    verdicts = [r["verdict"] for r in json.loads(out)["robots"].values()]
    # a fitting "no part" of a robot with forward steps: the comparison is computed for it
    assert any(v["part"] is None and not v["candidates"] and v["fit"]["ok"] for v in verdicts)
    loaded = _modules_after(argv)
    assert "mirl.learning.verdicts" in loaded
    assert not [m for m in loaded if m == "scipy.stats" or m.startswith("scipy.stats.")]
