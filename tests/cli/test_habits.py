"""Command-line habits: a misspelt subcommand, option or choice gets the close match; an unknown
option points to its subcommand's --help; every subcommand describes itself; `deik experiments`
speaks like the other commands (its error prefix, `--device gpu`)."""

import argparse

import pytest

from deik.cli.app import build_parser, main


def _error(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize(
    "argv, hint, helped",
    [
        (["slove", "chain:3"], "did you mean 'solve'?", "deik"),
        (["retaget", "x.bvh"], "did you mean 'retarget'?", "deik"),
        (["clip", "x.bvh", "--out", "y.bvh", "--plant-fet", "auto"], "did you mean '--plant-feet'", "deik clip"),
        (["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--genrations", "5"], "'--generations'", "deik solve"),
        (["retarget", "x.bvh", "--out", "y.bvh", "--sacle", "a=1"], "did you mean '--scale'", "deik retarget"),
        (["info", "chain:3", "--bsae", "a"], "did you mean '--base'", "deik info"),
        (["experiments", "fig2", "--out", "x", "--quik"], "did you mean '--quick'", "deik experiments"),
        (["solve", "chain:3", "--dtype", "float23"], "did you mean 'float32'", "deik solve"),
    ],
)
def test_a_misspelling_gets_the_close_match_and_its_subcommand_s_help(argv, hint, helped, capsys):
    err = _error(argv, capsys)
    assert hint in err and err.rstrip().endswith(f"(see `{helped} --help`)"), err


def test_an_unknown_option_with_nothing_close_still_names_the_subcommand_s_help(capsys):
    err = _error(["limits", "x.bvh", "--out", "l.json", "--zzzz"], capsys)
    assert "unrecognized arguments: --zzzz (see `deik limits --help`)" in err


def test_every_subcommand_is_listed_and_describes_itself(capsys):
    commands = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    listed = {action.dest: action.help for action in commands._choices_actions}
    assert set(listed) == set(commands.choices) and len(listed) == 9
    for name, parser in commands.choices.items():
        assert listed[name] and parser.description, name
        assert main([name, "--help"]) == 0
        assert parser.description in " ".join(capsys.readouterr().out.split()), name


def test_experiments_speaks_like_the_other_commands(tmp_path, capsys):
    err = _error(["experiments", "fig99", "--out", str(tmp_path)], capsys)
    assert "unknown experiment 'fig99'" in err
    err = _error(["experiments", "fig8", "--device", "cuda", "--out", str(tmp_path)], capsys)
    assert "invalid choice: 'cuda' (choose from 'auto', 'cpu', 'gpu')" in err
    parser = build_parser()
    assert parser.parse_args(["experiments", "fig8", "--device", "gpu", "--out", "x"]).device == "gpu"
    assert parser.parse_args(["solve", "chain:3", "--device", "gpu"]).device == "gpu"  # the same word
