"""Every `deik` command in README.md's bash blocks runs as written, in order (a later command may
read what an earlier one wrote), from a folder laid out like a clone beside shared/, and the
README's Python example runs and meets its goals."""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text()
SLOW = ("deik demo", "deik warmup")  # make demo runs both, and the demo's scenarios have their own tests


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.S)


def _commands() -> list[str]:
    """The `deik ...` lines of the bash blocks, continuation lines joined, comments dropped."""
    commands = []
    for block in _blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if line.startswith("deik "):
                commands.append(line)
    return commands


def test_the_readme_has_commands_to_check():
    assert len(_commands()) >= 10


@pytest.mark.shared_data
def test_every_readme_command_runs_as_written(tmp_path, shared_data):
    clone = tmp_path / "deik"
    clone.mkdir()
    (tmp_path / "shared").symlink_to(shared_data.parent)
    (clone / "examples").symlink_to(ROOT / "examples")
    deik = [sys.executable, "-c", "import sys; from deik.cli import main; sys.exit(main())"]
    gpu = (
        subprocess.run(
            [*deik[:2], "from numba import cuda; print(cuda.is_available())"], capture_output=True, text=True
        ).stdout.strip()
        == "True"
    )
    ran = 0
    for command in _commands():
        if command.startswith(SLOW) or ("--device gpu" in command and not gpu):
            continue
        run = subprocess.run(
            deik + shlex.split(command)[1:],
            cwd=clone,
            capture_output=True,
            text=True,
            timeout=900,
            env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        )
        assert run.returncode == 0, f"{command}\n{run.stderr[-2000:]}"
        ran += 1
    assert ran >= 10


def test_the_python_example_runs_and_meets_its_goals(capsys):
    (code,) = _blocks("python")
    namespace = {}
    exec(compile(code, "README.md", "exec"), namespace)
    result = namespace["result"]
    assert bool(result.converged) and all(bool(goal.met) for goal in result.goals)
    assert "pelvis" in namespace["pose"] and capsys.readouterr().out.count("met=True") == len(result.goals)
