"""The parser built from the option types and tables: every flag's bound and choice is its
option's, refused in one line that names the sub-command and the flag; an unknown flag, method,
world, experiment or sub-command gets the nearest known one; help lists every experiment."""

from __future__ import annotations

import math

import pytest

from mirl.cli import main
from mirl.cli.parser import build_parser
from mirl.experiments.conditions import EXPERIMENTS, experiment_names
from mirl.experiments.options import RunProtocol, SweepOptions
from mirl.learning.options import LearnOptions

LEARN = ["learn", "--scenario", "boyd2", "--observations", "o.csv"]
EXPERIMENT = ["experiment", "selftest", "--out", "unused"]

# (argv, the one line's text after "mirl COMMAND: error: ")
FLAG_ERRORS = [
    (["run", "--obs-steps", "0"], "argument --obs-steps: must be an integer in [1, 10000], got 0"),
    (["run", "--obs-steps", "x"], "argument --obs-steps: 'x' is not an integer"),
    (["run", "--watch-until-seen", "0"], "argument --watch-until-seen: must be an integer in [1, "),
    (["run", "--max-wait", "-1"], "argument --max-wait: must be an integer in [0, 10000], got -1"),
    (["run", "--p", "1.5"], "argument --p: must be a number in [0, 1], got 1.5"),
    (["run", "--go-rule", "adaptiv"], "argument --go-rule: unknown go rule 'adaptiv' (did you "
     "mean 'adaptive' or 'adaptive-posterior'? known: adaptive, adaptive-posterior, value)"),
    (["run", "--em-init", "zeros"], "argument --em-init: unknown EM initialisation 'zeros' "
     "(known: intended, uniform)"),
    (["run", "--seed", "-1"], "argument --seed: must be an integer in [0, 2^63 - 1], got -1"),
    (["run", "--max-memory", "-1G"], "argument --max-memory: '-1G' is not a size such as 4G"),
    (["run", "--observability", "-inf"], "argument --observability: must be a number in [0, 1], "
     "got -inf"),
    (["run", "--p", "-.5"], "argument --p: must be a number in [0, 1], got -0.5"),
    (["run", "--observability", "0.1_4"], "argument --observability: '0.1_4' is not a number"),
    (["run", "--observability", "1e-400"], "argument --observability: '1e-400' is too small for a "
     "float, which would read it as 0"),
    (["run", "--obs-steps", "1_000"], "argument --obs-steps: '1_000' is not an integer"),
    (["run", "--method", "mirl_t"], "argument --method: unknown method 'mirl_t' (did you mean "
     "'mirl-t' or 'mirl'? known: mirl-t, mirl, known-r-t, known-r, dbn-em, random, oracle)"),
    (["run", "--world", "phisics"], "argument --world: unknown world 'phisics' (did you mean "
     "'physics'? known: grid, physics)"),
    ([*LEARN, "--max-iterations", "101"], "argument --max-iterations: must be an integer in [1, "
     "100], got 101"),
    ([*LEARN, "--label-tol", "nan"], "argument --label-tol: must be a number in [0, 1], got nan"),
    ([*LEARN, "--objective", "count"], "argument --objective: unknown objective 'count' (did you "
     "mean 'counts'? known: counts, likelihood, both, sequence)"),
    ([*LEARN, "--optimizer", "nelder_mead"], "argument --optimizer: unknown optimizer "
     "'nelder_mead' (did you mean 'nelder-mead'? known: nelder-mead, lbfgs)"),
    ([*LEARN, "--method", "random"], "argument --method: unknown method 'random' (known: mirl-t, "
     "mirl, known-r-t, known-r, dbn-em)"),
    ([*EXPERIMENT, "--runs", "0"], "argument --runs: must be an integer in [1, 100000], got 0"),
    ([*EXPERIMENT, "--workers", "2000"], "argument --workers: must be an integer in [1, 1024]"),
    ([*EXPERIMENT, "--seed", "2e3"], "argument --seed: '2e3' is not an integer"),
    ([*EXPERIMENT, "--progress-every", "0"], "argument --progress-every: must be an integer in "
     "[1, 100000], got 0"),
    ([*EXPERIMENT, "--dask-scheduler", "h:99999"], "argument --dask-scheduler: must be an address "
     "HOST:PORT (e.g. tcp://127.0.0.1:8786), got 'h:99999'"),
    ([*EXPERIMENT, "--world", "phisics"], "argument --world: unknown world 'phisics' (did you "
     "mean 'physics'? known: grid, physics)"),
    ([*EXPERIMENT, "--go-rule", "values"], "argument --go-rule: unknown go rule 'values' (did "
     "you mean 'value'?"),
    (["experiment", "fig4"], "argument NAME: unknown experiment 'fig4' (did you mean 'fig4"),
    (["experiment", "fig9"], "argument NAME: unknown experiment 'fig9' (did you mean 'fig3'"),
    (["run", "--sead", "3"], "unrecognized argument --sead (did you mean --seed?)"),
    (["run", "--obs-stesp=3"], "unrecognized argument --obs-stesp=3 (did you mean --obs-steps?)"),
    ([*LEARN, "--max-iteratoins", "3"], "unrecognized argument --max-iteratoins (did you mean "
     "--max-iterations?)"),
    (["run", "extra"], "unrecognized argument extra (see mirl run --help)"),
    # argparse keeps the last of a flag given twice: the first setting would go without a word
    (["run", "--seed", "1", "--seed", "2"], "argument --seed: given twice (--seed 1 and --seed "
     "2); give it once"),
    (["simulate", "--scenario", "boyd2", "--scenario", "boydright"], "argument --scenario: given "
     "twice (--scenario boyd2 and --scenario boydright); give it once"),
    (["simulate", "--pose-noise", "0.1", "2", "--pose-noise", "0.1", "3"], "argument "
     "--pose-noise: given twice (--pose-noise 0.1 2.0 and --pose-noise 0.1 3.0); give it once"),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "text"), FLAG_ERRORS, ids=[" ".join(a) for a, _ in FLAG_ERRORS])
def test_a_bad_flag_is_one_line_naming_the_command_and_the_flag(capsys, argv, text):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"mirl {argv[0]}: error: {text}"), lines[0]


def test_a_flag_given_twice_with_one_value_is_that_value():
    args = build_parser().parse_args(["run", "--seed", "3", "--seed", "3", "--json"])
    assert args.seed == 3 and not hasattr(args, "_mirl_given")

    # a value that is not equal to itself (nan, where a flag's type lets it through) is still
    # one value given twice
    from mirl.cli.flags import OneLineParser

    parser = OneLineParser(prog="t")
    parser.add_argument("--x", type=float)
    assert math.isnan(parser.parse_args(["--x", "nan", "--x", "nan"]).x)


def test_every_option_flag_that_takes_a_value_has_its_refusal_above():
    tested = {a for argv, _ in FLAG_ERRORS for a in argv if a.startswith("--")}
    for options in (LearnOptions, RunProtocol, SweepOptions):
        for spec in options.__options__.values():
            switch = isinstance(spec.default, bool)
            if spec.flag is not None and not switch:
                assert spec.flag in tested, spec.flag


def test_an_unknown_command_gets_the_nearest(capsys):
    with pytest.raises(SystemExit):
        main(["rn"])
    err = capsys.readouterr().err.strip()
    assert err.startswith("mirl: error: argument COMMAND: unknown command 'rn' (did you mean "
                          "'run'? known: show-map, simulate,")  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "text"),
    [
        (["run", "--p", "0.5"], "--p applies to the methods mirl and known-r"),
        (["run", "--method", "random", "--em-init", "uniform"], "--em-init applies to the method"),
        (["run", "--watch-until-seen", "1801"], "--watch-until-seen must be at most max_obs_steps"),
        (["run", "--obs-steps", "5", "--watch-until-seen", "3"], "--obs-steps (a fixed time)"),
        (["experiment", "fig4b", "--em-init", "uniform"], "--em-init: experiment fig4b has no"),
        (["experiment", "selftest", "--go-rule", "value"], "--go-rule: experiment selftest has no"),
        # options a method never reads (mirl.learning.methods: its sources' and PART_OPTIONS)
        ([*LEARN, "--method", "known-r", "--max-iterations", "3"], "--max-iterations applies "
         "to the method mirl-t only, not known-r (it does not relabel the observed steps)"),
        ([*LEARN, "--method", "known-r", "--objective", "counts"], "--objective applies to the "
         "methods mirl-t, mirl and dbn-em only, not known-r (its reward: the scenario's true"),
        ([*LEARN, "--method", "known-r", "--optimizer", "lbfgs"], "--optimizer applies to the "
         "methods mirl-t, mirl and dbn-em only, not known-r"),
        ([*LEARN, "--method", "known-r-t", "--label-tol", "0.1"], "--label-tol applies to the "
         "method mirl-t only, not known-r-t"),
        ([*LEARN, "--method", "known-r-t", "--objective", "sequence"], "--objective applies to "
         "the methods mirl-t, mirl and dbn-em only, not known-r-t"),
        ([*LEARN, "--method", "known-r-t", "--max-iterations", "5"], "--max-iterations applies"),
        ([*LEARN, "--method", "known-r-t", "--optimizer", "lbfgs"], "--optimizer applies"),
        ([*LEARN, "--method", "dbn-em", "--max-iterations", "5"], "--max-iterations applies to "
         "the method mirl-t only, not dbn-em"),
        ([*LEARN, "--method", "mirl", "--max-iterations", "2"], "--max-iterations applies to the "
         "method mirl-t only, not mirl"),
        ([*LEARN, "--method", "mirl", "--label-tol", "0"], "--label-tol applies to the method "
         "mirl-t only, not mirl"),
        (["run", "--method", "random", "--go-rule", "value"], "--go-rule applies to the methods "
         "mirl-t, mirl, known-r-t, known-r, dbn-em and oracle only, not random (it does not plan"),
        (["run", "--method", "random", "--go-rule", "adaptive"], "--go-rule applies"),
        (["run", "--method", "random", "--learn-once"], "--learn-once applies to the methods "
         "mirl-t, mirl, known-r-t, known-r and dbn-em only, not random (it learns no models"),
        (["run", "--method", "oracle", "--learn-once"], "--learn-once applies to the methods "
         "mirl-t, mirl, known-r-t, known-r and dbn-em only, not oracle"),
        # a part damaged twice would keep the last silently, in every command that takes it
        (["simulate", "--scenario", "boyd2", "--damage", "J:left_wheel=0.5", "--damage",
          "J:left_wheel=0.9"], "--damage J:left_wheel given twice (J:left_wheel=0.5 and "
         "J:left_wheel=0.9)"),
        (["run", "--damage", "I:right_wheel=0.5", "--damage", "J:left_wheel=0.6", "--damage",
          "I:right_wheel=0.5"], "--damage I:right_wheel given twice"),
        ([*LEARN, "--damage", "J:left_wheel=0.5", "--damage", "J:left_wheel=0.9"],
         "--damage J:left_wheel given twice"),
        (["learn-transitions", "--scenario", "boyd2", "--observations", "o.csv", "--damage",
          "J:left_wheel=0.5", "--damage", "J:left_wheel=0.9"], "--damage J:left_wheel given"),
        # --damage where nothing reads the truth it sets (pose data: test_robot_data.py)
        (["convert", "in.csv", "out.csv", "--scenario", "boyd2", "--damage", "J:left_wheel=0.5"],
         "--damage J:left_wheel=0.5: changes nothing here: convert does not simulate"),
        (["learn-transitions", "--scenario", "boyd2", "--observations", "o.csv", "--labels",
          "perception", "--damage", "J:left_wheel=0.5"], "--damage J:left_wheel=0.5: changes "
         "nothing here: --labels perception labels the steps by what L saw"),
    ],
)  # fmt: skip
def test_options_that_cannot_work_together_are_refused_by_flag(capsys, argv, text):
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"mirl {argv[0]}: error: {text}"), lines
    assert "Traceback" not in err


def test_a_method_s_own_options_are_accepted_and_defaults_never_refused(tmp_path, capsys):
    """The flags refused above, where they apply; a flag left out (its default) is never
    refused, whichever the method."""
    obs = str(tmp_path / "o.csv")
    sim = ["simulate", "--scenario", "boyd2", "--steps", "60", "--seed", "1"]
    assert main([*sim, "--observability", "1", "--observations", obs]) == 0
    learn = ["learn", "--scenario", "boyd2", "--observations", obs, "--observability", "1"]
    for argv in (
        [*learn, "--max-iterations", "1", "--label-tol", "0.5", "--objective", "counts",
         "--optimizer", "lbfgs"],  # mirl-t
        [*learn, "--method", "mirl", "--objective", "counts", "--optimizer", "lbfgs", "--p", "0.8"],
        [*learn, "--method", "known-r"],
        [*learn, "--method", "known-r-t", "--damage", "J:left_wheel=0.6"],
        ["learn-transitions", "--scenario", "boyd2", "--observations", obs, "--damage",
         "J:left_wheel=0.6", "--damage", "I:left_wheel=0.6"],  # true-policy labels
        ["run", "--method", "oracle", "--go-rule", "value", "--obs-steps", "10", "--max-wait", "5"],
        ["run", "--method", "known-r", "--learn-once", "--obs-steps", "10", "--max-wait", "5"],
        ["run", "--method", "random", "--obs-steps", "10", "--max-wait", "5"],
        [*sim, "--damage", "J:left_wheel=0.5", "--damage", "J:right_wheel=0.5"],
    ):  # fmt: skip
        assert main(argv) == 0, (argv, capsys.readouterr().err)
    # left out, the options some method does not read stay unset: the defaults are the library's
    left_out = vars(build_parser().parse_args(LEARN))
    assert all(left_out[o] is None for o in ("max_iterations", "label_tol", "objective",
                                             "optimizer", "p", "em_init"))  # fmt: skip
    left_out = vars(build_parser().parse_args(["run"]))
    assert left_out["go_rule"] is None and left_out["relearn"] is True


def _flags(command: str) -> dict:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return {s: a for a in sub._actions for s in a.option_strings}


@pytest.mark.parametrize(
    ("command", "options"),
    [
        ("learn", LearnOptions),
        ("run", RunProtocol),
        ("run", LearnOptions),
        ("experiment", SweepOptions),
    ],
)
def test_each_flag_is_its_options_declaration(command, options):
    flags = _flags(command)
    for name, spec in options.__options__.items():
        if spec.flag is None or spec.flag not in flags:
            continue
        action = flags[spec.flag]
        assert action.dest == name
        if spec.choices is not None:
            assert tuple(action.choices) == spec.choices
        if action.type is not None and action.default is not None:
            assert action.default == spec.default  # the declared default, written once


def test_the_flags_each_command_takes_from_the_options():
    assert {"--p", "--max-iterations", "--label-tol", "--objective", "--optimizer",
            "--em-init"} <= set(_flags("learn"))  # fmt: skip
    assert {"--obs-steps", "--watch-until-seen", "--max-wait", "--go-rule", "--learn-once", "--p",
            "--em-init"} <= set(_flags("run"))  # fmt: skip
    assert {spec.flag for spec in SweepOptions.__options__.values()} <= set(_flags("experiment"))
    # every option of learning with a flag is one of learn's, a new one included
    flagged = {spec.flag for spec in LearnOptions.__options__.values() if spec.flag is not None}
    assert flagged <= set(_flags("learn"))


def test_experiment_help_lists_every_experiment(capsys):
    with pytest.raises(SystemExit):
        main(["experiment", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in experiment_names():
        assert f"{name}: {' '.join(EXPERIMENTS[name].description.split())}" in text
    assert "verdicts" in text and "selftest" not in text
    with pytest.raises(SystemExit):
        main(["--help"])
    top = " ".join(capsys.readouterr().out.split())
    assert "`mirl experiment --help` lists them" in top
