"""What the commands say on stderr (deik.console): the progress bar with --progress and on a
terminal, nothing but results and warnings with --quiet, diagnostics with --verbose or
DEIK_LOG, and one-line errors for a bad level or contradicting flags."""

import logging

import pytest

from deik.cli.app import build_parser, main
from deik.experiments import runner
from deik.experiments.demo import chain_scenarios, run_demo
from helpers import shared_path

# comfort has no tolerance, so the solve runs its whole budget and the bar reaches 100 %
SOLVE = "solve chain:4 --reach tip 2 1 0 --comfort 0.5 --population 24 --generations 150".split()
BVH_SOLVE = ["--frame", "2", "--reach", "LeftElbow_end", "0.42", "0.95", "-0.28", "--generations", "30"]


@pytest.fixture(autouse=True)
def no_level_from_the_environment(monkeypatch):
    monkeypatch.delenv("DEIK_LOG", raising=False)
    yield
    logging.getLogger("deik").setLevel(logging.NOTSET)  # main() set it; leave the next test as it found it


def test_progress_draws_the_bar_even_into_a_pipe(capsys):
    assert main([*SOLVE, "--progress"]) == 0
    captured = capsys.readouterr()
    assert "deik solve: 100%" in captured.err and "best fitness" in captured.err
    assert "position tip" in captured.out


def test_without_a_terminal_or_progress_no_bar_is_drawn(capsys):
    assert main(SOLVE) == 0
    assert "deik solve" not in capsys.readouterr().err


@pytest.mark.shared_data
def test_quiet_leaves_only_the_results(capsys):
    argv = ["solve", "--skeleton", str(shared_path("humanoid", "humanoid3d_walk.bvh")), *BVH_SOLVE]
    assert main(argv) == 0
    assert "note: masses" in capsys.readouterr().err  # a BVH solve has notes to silence
    assert main([*argv, "--quiet", "--progress"]) == 0  # --quiet wins over --progress for the bar
    captured = capsys.readouterr()
    assert captured.err == "" and "position LeftElbow_end" in captured.out


def test_verbose_and_deik_log_print_the_diagnostics(capsys, monkeypatch):
    assert main([*SOLVE, "--verbose"]) == 0
    err = capsys.readouterr().err
    assert "debug: deik.solver.solve: launch of" in err and "debug: deik.io.load: loaded chain:4" in err
    monkeypatch.setenv("DEIK_LOG", "debug")
    assert main(SOLVE) == 0
    assert "debug: deik.solver.solve: solved 1 problem(s) of 4 DOFs" in capsys.readouterr().err
    monkeypatch.setenv("DEIK_LOG", "warning")
    assert main([*SOLVE[:-6], *SOLVE[-4:], "--start", "0", "0", "0", "0"]) == 0  # without --comfort: a note
    assert "comfort keeps the pose" not in capsys.readouterr().err  # a note, below the warning level


@pytest.mark.parametrize(
    "argv, env, message",
    [
        ([*SOLVE, "--quiet", "--verbose"], None, "argument --verbose/-v: not allowed with argument --quiet/-q"),
        (SOLVE, "chatty", "DEIK_LOG='chatty' names no level; use one of debug, info, warning, error"),
    ],
)
def test_a_bad_level_or_contradicting_flags_get_one_line(capsys, monkeypatch, argv, env, message):
    if env:
        monkeypatch.setenv("DEIK_LOG", env)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and message in err and err.count("\n") == 1


def test_every_command_that_works_a_while_takes_quiet_and_verbose():
    commands = build_parser()._subparsers._group_actions[0].choices
    for name in ("solve", "clip", "retarget", "demo", "warmup", "info", "limits"):
        flags = {flag for action in commands[name]._actions for flag in action.option_strings}
        assert {"--quiet", "--verbose"} <= flags, name
    for name in ("solve", "clip", "retarget", "demo", "warmup"):
        assert "--progress" in {f for a in commands[name]._actions for f in a.option_strings}, name
    flags = {flag for action in runner.build_parser()._actions for flag in action.option_strings}
    assert {"--quiet", "--verbose", "--progress"} <= flags


def test_the_demo_and_the_experiments_draw_their_bars(tmp_path, capsys):
    run_demo(tmp_path / "demo", chain_scenarios(n_links=3, seed=1), show=True)
    assert "deik demo: 100%" in capsys.readouterr().err
    assert runner.main(["fig7", "--quick", "--out", str(tmp_path / "fig"), "--progress"]) == 0
    captured = capsys.readouterr()
    assert "deik experiments: 100%" in captured.err and "fig7:" in captured.out
    assert runner.main(["fig7", "--quick", "--out", str(tmp_path / "fig"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""
