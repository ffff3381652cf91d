"""Every command run in a pipe, as a script or a log would run it: its stderr holds no progress bar
unless --progress asks for one (issue: folder runs wrote kilobytes of bar redraws into logs)."""

import os
import re
import shutil
import subprocess
import sys

import pytest

from helpers import ROOT, shared_path

BAR = re.compile(r"\r|\d+%\|")  # a bar's carriage returns, or its "42%|" as a non-terminal would get it


def _deik(arguments: list[str], cwd) -> str:
    """stderr of `deik ARGUMENTS` run with stdout and stderr piped (no terminal)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run(
        [sys.executable, "-m", "deik", *map(str, arguments)], cwd=cwd, env=env, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stderr


def _folder(tmp_path):
    clips = tmp_path / "clips"
    clips.mkdir()
    shutil.copy(shared_path("humanoid", "humanoid3d_walk.bvh"), clips / "walk.bvh")
    return clips


@pytest.mark.shared_data
def test_folder_runs_draw_no_bar_into_a_pipe_unless_asked(tmp_path):
    clips = _folder(tmp_path)
    for command in (
        ["clip", clips, "--out", tmp_path / "fixed"],
        ["retarget", clips, "--scale", "LeftHip=1.1", "--out", tmp_path / "long"],
    ):
        err = _deik(command, tmp_path)
        assert not BAR.search(err), (command[0], err[-500:])
    err = _deik(["clip", clips, "--out", tmp_path / "again", "--progress"], tmp_path)
    assert BAR.search(err) and "clips" in err  # --progress draws them: the check above can fail


@pytest.mark.shared_data
def test_one_clip_commands_draw_no_bar_into_a_pipe(tmp_path):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    for command in (
        ["clip", walk, "--balance", "--out", tmp_path / "fixed.bvh"],
        ["retarget", walk, "--scale", "LeftHip=1.1", "--out", tmp_path / "long.bvh"],
        ["limits", walk, "--out", tmp_path / "limits.json"],
        ["info", walk],
    ):
        err = _deik(command, tmp_path)
        assert not BAR.search(err), (command[0], err[-500:])


def test_solve_warmup_demo_and_experiments_draw_no_bar_into_a_pipe(tmp_path):
    solve = ["solve", "chain:12", "--reach", "tip", "6", "5", "0", "--generations", "4000", "--polish", "0"]
    for command in (solve, ["warmup", "--dtype", "float64"], ["experiments", "fig7", "--quick", "--out", tmp_path]):
        err = _deik(command, tmp_path)
        assert not BAR.search(err), (command[0], err[-500:])
    assert BAR.search(_deik([*solve, "--progress"], tmp_path))  # the same solve draws one when asked
    code = (
        "from deik.experiments.demo import chain_scenarios, run_demo\n"
        f"run_demo({str(tmp_path / 'demo')!r}, chain_scenarios(n_links=3, seed=1))\n"  # as `deik demo` calls it
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert run.returncode == 0 and not BAR.search(run.stderr), run.stderr[-500:]
