"""--self-collision on the command line: `deik solve` keeps the humanoid's hand out of its torso
where the plain reach goes through, and `deik clip` repairs the frames of a clip whose hand
passes through the chest; penetration measured by the NumPy oracle on what was written."""

import json
import re

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.objectives import reference
from deik.objectives.goals import LENGTH_TOLERANCE
from deik.solver.problem_file import load_problem

SMALL = ["--population", "64", "--generations", "300", "--seed", "1", "--restarts", "2"]


def penetration(skeleton, poses) -> np.ndarray:
    """(N,) the default SelfCollision's error of poses (N, D) on `skeleton`."""
    return reference.raw_errors(deik.Problem(skeleton, [deik.SelfCollision()]), np.atleast_2d(poses))[:, 0]


def _solve(tmp_path, name, *extra):
    h = deik.humanoid()
    rest = deik.forward_kinematics(h, h.reference)
    pelvis, chest = rest.position("pelvis"), rest.position("chest") + [0.0, 0.0, 0.03]
    out = tmp_path / f"{name}.json"
    argv = ["solve", "humanoid", "--reach", "pelvis", *map(str, pelvis), "--orient", "pelvis", "xyz", "0", "0", "0"]
    argv += ["--reach", "left_hand", *map(str, chest), *SMALL, "--dtype", "float64", "--out", str(out), *extra]
    assert main(argv) == 0
    return np.array(json.loads(out.read_text())["angles"])


def test_solve_flag_keeps_the_hand_out_of_the_torso(tmp_path, capsys):
    h = deik.humanoid()
    assert penetration(h, _solve(tmp_path, "free"))[0] > 0.1
    assert penetration(h, _solve(tmp_path, "kept", "--self-collision", "0"))[0] <= LENGTH_TOLERANCE
    assert "self collision" in capsys.readouterr().out


def test_clip_flag_repairs_the_frames_in_collision(tmp_path, capsys):
    h = deik.humanoid()
    through = _solve(tmp_path, "free")
    poses = h.reference + np.linspace(0.5, 0.95, 6)[:, None] * (through - h.reference)  # towards the chest
    source, fixed = tmp_path / "in.bvh", tmp_path / "out.bvh"
    deik.write_bvh(source, deik.Clip.from_poses(h, poses, 1.0 / 30.0))
    argv = ["clip", str(source), "--out", str(fixed), "--plant-feet", "none", "--self-collision", "0"]
    assert main([*argv, "--population", "48", "--generations", "200", "--seed", "0"]) == 0
    before, after = deik.read_bvh(source), deik.read_bvh(fixed)
    assert (penetration(before.skeleton, before.poses()) > 0.3).sum() == 2  # the hand in the chest
    inside = penetration(after.skeleton, after.poses()) > LENGTH_TOLERANCE
    # a blend at constant speed has no acceleration to spare: a repair that would make the hand
    # accelerate past 1.1 times its capture peak is taken back or refused, and its frame listed unmet
    printed = capsys.readouterr().out
    met = int(re.search(r"(\d+)/6 frames meet", printed)[1])
    assert met <= 6 - inside.sum()
    # the goal table names each row by its goal: the hand's depth in the chest was printed as "floor"
    assert re.search(r"^self-collision +mm +[1-9]", printed, re.M), printed
    assert not re.search(r"^floor +mm +[1-9]", printed, re.M), printed  # nothing of the body is under it
    deeper = penetration(after.skeleton, after.poses()) - penetration(before.skeleton, before.poses())
    assert (deeper <= LENGTH_TOLERANCE).all()  # what is taken back stays as the capture had it


SELF_COLLISION_TOML = """
skeleton = "humanoid"

[[goal]]
type = "self_collision"
margin = 0.01
radii = { left_wrist = 0.06 }
skip = 3
"""


def test_problem_file_reads_self_collision(tmp_path):
    path = tmp_path / "problem.toml"
    path.write_text(SELF_COLLISION_TOML)
    goal = load_problem(path).problem.goals[0]
    assert goal == deik.SelfCollision(margin=0.01, radii={"left_wrist": 0.06}, skip=3)
    path.write_text(SELF_COLLISION_TOML.replace("skip = 3", "skip = 1.5"))
    with pytest.raises(ValueError, match="goal 1 \\(self_collision\\): field 'skip' must be an integer >= 1"):
        load_problem(path)
    path.write_text(SELF_COLLISION_TOML.replace("left_wrist", "left_hand"))
    with pytest.raises(ValueError, match="goal 1 \\(self_collision\\): self collision: 'left_hand' is a site"):
        load_problem(path)
