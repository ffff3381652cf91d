"""README.md runs as written, from a clone: every line of its bash blocks in order (a later
command may read what an earlier one wrote), from a folder laid out like a clone beside shared/
(in one process: readme_commands.run_lines), and every Python block. A bash line
that is neither a `deik` command nor an example script must be in
readme_commands.EXCLUDED with the reason it cannot run here and what runs it
instead, so no line goes unchecked unnoticed; a solve that writes a pose JSON must meet every
goal within its tolerances, and the numbers the README states beside a command must be what it
measures (readme_figures); mypy checks the Python blocks against deik's real types.
tests/cli/test_wheel.py runs the same lines against a fresh wheel install."""

import os
import re
import subprocess
import sys

import pytest
from readme_commands import (
    EXCLUDED,
    MKDIR,
    OUTPUTS,
    ROOT,
    SLOW,
    bash_lines,
    blocks,
    clone_beside_shared,
    gpu_available,
    run_lines,
    runnable,
)
from readme_figures import FIGURES, check, command_record


def test_every_bash_line_is_run_or_excluded_with_a_reason():
    lines = bash_lines()
    unrun = [
        line for line in lines if not line.startswith(("deik ", "python examples/", MKDIR)) and line not in EXCLUDED
    ]
    assert unrun == [], "README bash lines that no test runs: run them or add them to EXCLUDED with a reason"
    assert set(EXCLUDED) <= set(lines), "EXCLUDED lists lines the README no longer has"
    assert all(any(line.startswith(slow) for line in lines) for slow in SLOW)
    assert sum(runnable(line, gpu=False) for line in lines) >= 13


def _table_units(printed: str) -> list[str]:
    """The units of the error and tolerance cells of `deik solve`'s goal table in `printed`."""
    lines = printed.splitlines()
    start = next(k for k, line in enumerate(lines) if line.split() == ["goal", "error", "tolerance", "met"])
    units = []
    for line in lines[start + 2 :]:
        cells = re.split(r" {2,}", line.strip())
        if len(cells) != 4 or cells[3] not in ("yes", "NO"):
            break
        units += [cell.split(" ", 1)[1].replace("rad+", "") for cell in cells[1:3] if cell != "-"]
    return units


@pytest.mark.slow  # every README command in turn: about 40 s on 2 cores
@pytest.mark.shared_data
def test_every_readme_line_runs_as_written(tmp_path, shared_data):
    clone = clone_beside_shared(tmp_path, shared_data)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    lines = [line for line in bash_lines() if runnable(line, gpu_available(sys.executable))]
    records = run_lines(lines, clone, sys.executable, env)
    for record in records:
        assert record["status"] == 0, f"{record['line']}\n{record['stderr']}"
        assert record.get("converged", True), f"{record['line']}: a README solve misses a goal"
        if record.get("length_unit"):  # the solve's table names the unit its pose file names
            assert set(_table_units(record["stdout"])) <= {record["length_unit"], "deg"}, record["line"]
    assert len(records) == len(lines) >= 13
    # the numbers the README states beside these commands are what they measure
    contradicted = []
    for figure in FIGURES:
        if not figure.from_results:
            contradicted += check(figure, command_record(figure, records, clone))
    assert contradicted == []

    assert sorted(path.name for path in clone.iterdir()) == ["examples", OUTPUTS]  # nothing else in the clone


WRITING_FLAGS = ("--out", "--plot", "--report", "--json", "--view")


def _outputs(line: str) -> list[str]:
    """The files and folders a README bash line writes: its output flags' values, and an
    example script's arguments that name a file in the outputs' folder."""
    words = line.split()
    if words[0] == "deik":
        return [words[k + 1] for k, word in enumerate(words[:-1]) if word in WRITING_FLAGS]
    return [word for word in words[2:] if "/" in word and not word.startswith(("../", "examples/"))]


def test_the_readme_commands_write_into_one_folder_and_never_reuse_a_name():
    lines = bash_lines()
    assert lines.index(MKDIR) < min(k for k, line in enumerate(lines) if _outputs(line))  # made before use
    written = [path for line in lines for path in _outputs(line)]
    assert len(written) >= 30 and all(path.startswith(f"{OUTPUTS}/") for path in written), written
    names = [path.rsplit("/", 1)[1] for path in written]  # a name once only, in any folder
    repeated = {name for name in names if names.count(name) > 1}
    assert repeated == set(), f"README commands write {sorted(repeated)} more than once"


def test_every_python_block_runs_and_the_first_meets_its_goals(capsys):
    code = blocks("python")
    assert code, "the README has no Python block"
    for number, block in enumerate(code):
        namespace = {}
        exec(compile(block, f"README.md python block {number + 1}", "exec"), namespace)
        if number == 0:  # the API example: a prioritised humanoid problem, every goal met
            result = namespace["result"]
            assert bool(result.converged) and all(bool(goal.met) for goal in result.goals)
            assert "pelvis" in namespace["pose"] and capsys.readouterr().out.count("met=True") == len(result.goals)
            # the units its comment lists are those the goals print
            listed = re.findall(r'"([^"]+)"', re.search(r"# .*in goal\.unit: (.*)", block)[1])
            assert {goal.unit for goal in result.goals} <= set(listed), listed


# Four mistakes a type checker must catch in code like the README's: a setting's name and a
# tolerance's type, a result field's type, a public name that does not exist. Each would pass if
# deik's lazily loaded names (PEP 562) reached mypy as Any.
WRONG = """
import deik
problem = deik.Problem(deik.chain(3), [deik.Position("tip", [1, 1, 0], tolerance="big")])
result = deik.solve(problem, populaton=64)
converged: str = result.converged
deik.solv(problem)
"""
WRONG_ERRORS = (
    'wrong.py:3: error: Argument "tolerance" to "Position" has incompatible type "str"',
    'wrong.py:4: error: Unexpected keyword argument "populaton" for "solve"; did you mean "population"?',
    'wrong.py:5: error: Incompatible types in assignment (expression has type "ndarray',
    'wrong.py:6: error: Module has no attribute "solv"',
)


@pytest.mark.slow  # mypy reads deik and NumPy: 40 s without its cache on two loaded cores
def test_mypy_passes_the_readme_python_blocks_and_sees_deik_s_real_types(tmp_path):
    pytest.importorskip("mypy", reason="mypy type-checks the README's Python: pip install mypy (in deik[test])")
    files = []
    for number, block in enumerate(blocks("python")):
        files.append(tmp_path / f"readme_block_{number + 1}.py")
        files[-1].write_text(block)
    (tmp_path / "wrong.py").write_text(WRONG)
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / "cache"), *map(str, files), "wrong.py"],
        cwd=tmp_path,
        env={**os.environ, "MYPYPATH": str(ROOT / "src")},
        capture_output=True,
        text=True,
    )
    errors = [line for line in run.stdout.splitlines() if ": error: " in line]
    assert [line for line in errors if not line.startswith("wrong.py")] == [], run.stdout
    for expected in WRONG_ERRORS:
        assert any(line.startswith(expected) for line in errors), (expected, run.stdout)
    assert len(errors) == len(WRONG_ERRORS), run.stdout
