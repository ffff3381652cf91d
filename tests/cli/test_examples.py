"""examples/: each audience's script runs as its docstring says and does what it claims, checked
here independently of what it prints; the joint-limits table keeps a solve within it."""

import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import deik
from deik.cleanup.body import on_body
from deik.cleanup.metrics import sliding_steps
from deik.cli.app import main
from deik.model.kinematics import forward_kinematics
from helpers import ROOT

EXAMPLES = ROOT / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_script(name: str, *arguments: str, cwd, shared=None) -> str:
    """Run examples/NAME with `arguments` in `cwd` as a user would (deik importable, the data
    beside the clone); its stdout. Fails with its stderr when it exits non-zero."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    if shared is not None:
        env["DEIK_SHARED_DATA"] = str(shared)
    run = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *arguments], cwd=cwd, env=env, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stdout


def test_every_example_is_tested_here():
    tested = {"animator_fix_contacts.py", "robot_arm_pose.py", "compare_de_settings.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


@pytest.mark.shared_data
def test_the_animator_script_plants_the_walk_s_feet(tmp_path, shared_data):
    printed = run_script("animator_fix_contacts.py", cwd=tmp_path, shared=shared_data)
    original = deik.read_bvh(shared_data / "humanoid" / "humanoid3d_walk.bvh")
    fixed = deik.read_bvh(tmp_path / "walk_planted.bvh")  # the default output, in the working folder
    assert fixed.n_frames == original.n_frames and fixed.layout == original.layout
    cleaned = deik.clean_clip(original, deik.CleanOptions(plant_feet="auto", seed=0))  # what the script ran
    np.testing.assert_allclose(fixed.frames, cleaned.clip.frames, atol=1e-4)
    body, contacts, met = cleaned.fix.body, cleaned.contacts, cleaned.fix.met
    feet = [k for k, site in enumerate(contacts.sites) if site in body.sole_names]
    index = [body.skeleton.frame_index(contacts.sites[k]) for k in feet]

    def sliding(clip, frames):  # along the ground, over the feet's contacts in `frames`
        kin = forward_kinematics(body.skeleton, on_body(clip, body).frames)
        return np.nanmax(sliding_steps(kin, index, contacts.mask[:, feet] & frames[:, None], body.skeleton.up))

    assert sliding(fixed, met) < 0.001 < sliding(original, met)  # planted where met; the capture slid more
    assert f"{met.sum()}/{original.n_frames} frames" in printed


@pytest.mark.shared_data
def test_the_roboticist_script_meets_every_tool_pose(tmp_path, shared_data):
    printed = run_script("robot_arm_pose.py", str(shared_data / "robots" / "panda.urdf"), "12", cwd=tmp_path)
    assert "met 12/12" in printed
    millimetres, degrees = map(float, re.search(r"worst errors ([0-9.]+) mm and ([0-9.]+) degrees", printed).groups())
    assert millimetres <= 0.01 and degrees <= 0.01
    joints = re.findall(r"^  (panda_joint\d) +(-?[0-9.]+)$", printed, flags=re.M)
    assert [name for name, _ in joints] == [f"panda_joint{k}" for k in range(1, 8)]  # keyed by joint name


def test_the_researcher_script_compares_settings_and_draws_them(tmp_path):
    printed = run_script("compare_de_settings.py", "4", "de.png", cwd=tmp_path)
    rows = [line for line in printed.splitlines() if re.match(r"(paper|current-to-best|deik's default)", line)]
    assert len(rows) == 3 and re.search(r"deik's default.*  100%  ", rows[2])
    assert (tmp_path / "de.png").read_bytes()[:8] == PNG_MAGIC


@pytest.mark.shared_data
def test_the_limits_table_example_keeps_the_panda_within_it(tmp_path, shared_data, capsys):
    table = json.loads((EXAMPLES / "panda_limits.json").read_text())
    out = tmp_path / "pose.json"
    argv = ["solve", "--skeleton", str(shared_data / "robots" / "panda.urdf"), "--base", "panda_link0"]
    argv += ["--tip", "panda_hand_tcp", "--reach", "panda_hand_tcp", "0.4", "0.2", "0.5"]
    argv += ["--limits", str(EXAMPLES / "panda_limits.json"), "--out", str(out), "--seed", "0"]
    assert main(argv) == 0, capsys.readouterr().err
    angles = json.loads(out.read_text())["angles_by_joint"]
    for joint, (lower, upper) in table.items():
        assert lower - 1e-6 <= math.degrees(angles[joint][0]) <= upper + 1e-6, joint
