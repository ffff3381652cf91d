"""README.md runs as written, from a clone: every line of its bash blocks in order (a later
command may read what an earlier one wrote), from a folder laid out like a clone beside shared/
(in one process: readme_commands.run_lines), and every Python block. A bash line
that is neither a `deik` command nor an example script must be in
readme_commands.EXCLUDED with the reason it cannot run here and what runs it
instead, so no line goes unchecked unnoticed; a solve that writes a pose JSON must meet every
goal within its tolerances. tests/cli/test_wheel.py runs the same lines against a fresh wheel
install."""

import os
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


def test_every_bash_line_is_run_or_excluded_with_a_reason():
    lines = bash_lines()
    unrun = [
        line for line in lines if not line.startswith(("deik ", "python examples/", MKDIR)) and line not in EXCLUDED
    ]
    assert unrun == [], "README bash lines that no test runs: run them or add them to EXCLUDED with a reason"
    assert set(EXCLUDED) <= set(lines), "EXCLUDED lists lines the README no longer has"
    assert all(any(line.startswith(slow) for line in lines) for slow in SLOW)
    assert sum(runnable(line, gpu=False) for line in lines) >= 13


@pytest.mark.shared_data
def test_every_readme_line_runs_as_written(tmp_path, shared_data):
    clone = clone_beside_shared(tmp_path, shared_data)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    lines = [line for line in bash_lines() if runnable(line, gpu_available(sys.executable))]
    records = run_lines(lines, clone, sys.executable, env)
    for record in records:
        assert record["status"] == 0, f"{record['line']}\n{record['stderr']}"
        assert record.get("converged", True), f"{record['line']}: a README solve misses a goal"
    assert len(records) == len(lines) >= 13
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
