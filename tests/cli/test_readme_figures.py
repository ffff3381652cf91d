"""The README's numbers against their measurements (tests/readme_figures.py): every number in the
prose beside a command is a figure, measured, or a setting, explained; each figure a results file
measures agrees with it (docs/install.md's too); and the check catches a drifted figure, a number nobody explained and a
pattern that no longer matches. The figures a README command measures are checked by
tests/cli/test_readme.py::test_every_readme_line_runs_as_written, once the commands have run."""

import re

import pytest
from readme_commands import README, bash_lines
from readme_figures import (
    FIGURES,
    SETTINGS,
    agrees,
    check,
    collapsed,
    results_record,
    unexplained,
    values,
)

FROM_RESULTS = [figure for figure in FIGURES if figure.from_results]


def test_every_number_beside_a_command_is_a_figure_or_a_setting():
    assert unexplained() == [], "add each number to FIGURES (measured) or SETTINGS (why it is not) in readme_figures"
    text = collapsed(README.read_text())
    assert [pattern for pattern in SETTINGS if not re.search(pattern, text)] == [], "SETTINGS the README no longer has"


def test_every_command_figure_names_one_readme_command():
    lines = bash_lines()
    for figure in FIGURES:
        if not figure.from_results:
            assert sum(line.startswith(figure.source) for line in lines) == 1, figure.source


@pytest.mark.parametrize(
    "figure", FROM_RESULTS, ids=[f"{f.source.split('/')[-1]}:{f.pattern[:30]}" for f in FROM_RESULTS]
)
def test_the_readme_states_what_the_results_file_measures(figure):
    assert check(figure, results_record(figure)) == []


def test_a_drifted_figure_a_lost_pattern_and_an_unexplained_number_are_caught():
    text = README.read_text()
    (timing,) = [f for f in FIGURES if f.source.endswith("clip_frames.json")]
    record = results_record(timing)
    fixed_in = re.search(timing.pattern, collapsed(text))[1]
    drifted = collapsed(text).replace(f"fixed in {fixed_in} s", f"fixed in {float(fixed_in) * 2:.2f} s")
    (problem,) = check(timing, record, drifted)
    assert f"README.md states {float(fixed_in) * 2:.2f} where benchmarks/results/clip_frames.json measures" in problem
    lost = collapsed(text).replace("best of three runs", "the best of three runs")
    assert "0 matches" in check(timing, record, lost)[0]
    added = re.sub(
        r"\(on the walk below, (\d+) of its 39 frames\):", r"(on the walk below, \1 of its 39 frames, in 15 s):", text
    )
    new = [problem.split()[0] for problem in unexplained(added) if problem not in unexplained(text)]
    assert added != text and new == ["'15'"]


def test_a_stated_number_agrees_within_its_tolerance():
    assert values("7-27") == ["7", "27"] and values("-30") == ["-30"] and values("2,000") == ["2,000"]
    assert agrees("0.62", 0.6299, "shown") and agrees("0.62", 0.611, "shown") and not agrees("0.62", 0.64, "shown")
    assert agrees("28", 27.3, "shown") and not agrees("28", 26.9, "shown")
    assert agrees("3", 2.1, "at most") and not agrees("3", 3.01, "at most") and agrees("2,000", 2001, "at least")
    assert agrees("300", 299.0 * 1.1, 0.15) and not agrees("300", 400.0, 0.15)
    assert agrees("0.5", 0.47, 0.05) and not agrees("0.5", 0.39, 0.05)  # a fraction, or one unit of the last digit
