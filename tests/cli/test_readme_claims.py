"""README claims that no other test measures (docs/claims.md lists every claim and what measures
it): what `make demo` and `make test` do, the humanoid's size, the quaternion the README gives
for the Panda's roll-pitch-yaw, how far longer legs sink without a retarget, and the time `make
figures` states against the run that made docs/paper-reproduction.md."""

import math
import os
import re
import shutil
import subprocess

import numpy as np
import pytest

import deik
from deik.cleanup.contacts import detect_contacts
from deik.model.orientations import quaternion_matrix, rpy_matrix
from deik.retargeting.skeletons import scaled_bones
from helpers import ROOT, shared_path

README = (ROOT / "README.md").read_text()


def make_dry_run(target: str, tmp_path) -> list[str]:
    """The commands `make -n TARGET` would run in a fresh clone (no .venv yet)."""
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy(ROOT / name, tmp_path / name)
    # Under `make test` the outer make's MAKELEVEL/MAKEFLAGS reach this make, which would then print
    # "Entering directory" lines; a fresh environment for make is what a user's shell gives.
    env = {key: value for key, value in os.environ.items() if key not in ("MAKELEVEL", "MAKEFLAGS", "MFLAGS")}
    run = subprocess.run(
        ["make", "--no-print-directory", "-n", target],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return run.stdout.splitlines()


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_demo_installs_only_the_viz_extra_then_warms_up_and_runs_the_demo(tmp_path):
    lines = make_dry_run("demo", tmp_path)
    assert lines[0] == "python3 -m venv .venv"  # .venv on first use, nothing installed by hand
    installs = [line for line in lines if " pip install " in line and "--upgrade pip" not in line]
    assert installs == ['.venv/bin/python -m pip install --quiet -e ".[viz]"']
    assert lines[-2:] == [".venv/bin/deik warmup", ".venv/bin/deik demo --out demo_output"]


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_test_installs_the_test_extras_and_runs_ruff_then_the_suite(tmp_path):
    lines = make_dry_run("test", tmp_path)
    assert '.venv/bin/python -m pip install --quiet -e ".[test,viz]"' in lines
    assert lines[-3:-1] == [".venv/bin/ruff check .", ".venv/bin/ruff format --check ."]
    # the whole suite (no path, no -m selection), on every core
    suite = ".venv/bin/python -m pytest -q -n logical --maxprocesses 4 --dist loadfile --no-loadscope-reorder"
    assert lines[-1] == suite


def test_the_humanoid_has_the_size_the_readme_gives():
    count = re.search(r"deik\.humanoid\(\)  # (\d+) joints, (\d+) DOFs, de Leva segment masses, Y up", README)
    human = deik.humanoid()
    assert (human.n_joints, human.n_dofs) == (int(count[1]), int(count[2]))
    assert np.array_equal(human.up, [0, 1, 0])


def test_the_readme_quaternion_is_the_panda_command_s_roll_pitch_yaw():
    rpy = re.search(r"--orient panda_hand_tcp rpy (\S+) (\S+) (\S+)", README).groups()
    number = r"(-?[0-9.]+)"
    quaternion = re.search(rf"`quat-wxyz {number} {number}\s+{number} {number}`", README).groups()
    R = rpy_matrix(np.radians([float(v) for v in rpy]))
    turn = quaternion_matrix([float(v) for v in quaternion], "wxyz").T @ R
    assert math.degrees(math.acos(min(1.0, (np.trace(turn) - 1) / 2))) < 0.02  # four decimals


@pytest.mark.shared_data
def test_longer_legs_sink_as_far_as_the_readme_says_without_a_retarget():
    depth = float(re.search(r"10 % longer\s+legs put the\s+feet ([0-9.]+) cm under the floor", README)[1])
    clip = deik.read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))
    longer = scaled_bones(clip.skeleton, {"LeftHip": 1.1, "RightHip": 1.1})
    lowest = (deik.forward_kinematics(longer, clip.poses()).p_world_frame @ longer.up).min()
    assert (detect_contacts(clip).ground - lowest) * 100 == pytest.approx(depth, abs=0.05)


def test_make_figures_takes_the_time_the_readme_says():
    minutes = float(re.search(r"`make figures` reruns the paper's evaluation\s+\(about (\d+) minutes", README)[1])
    seconds = float(re.search(r"Total time: (\d+) s", (ROOT / "docs" / "paper-reproduction.md").read_text())[1])
    assert abs(seconds / 60 - minutes) <= 0.15 * minutes
