"""URDF robots as users bring them to the command line. One written in millimetres (a CAD
export; the format says metres): `deik info` names the unit it reads from the robot's size, and
`deik solve` reports in it and meets a distance within 1 mm by default, where 0.001 length units
(1 micrometre) left float32 short of converging; checked by deik's float64 forward kinematics
of the answer against the target, in millimetres; a BVH walk in centimetres or the CMU
database's unit alike. A goal on a link that --tip cut away is named as such, with the flag that
keeps it."""

import json
import re

import numpy as np
import pytest

import deik
from deik.cli.app import main
from tests.solver.test_continuous_joints import SCARA


def _scaled(text: str, factor: float) -> str:
    """The URDF `text` with every origin's xyz and prismatic limit scaled by `factor`."""

    def scaled_xyz(match):
        return 'xyz="' + " ".join(f"{float(v) * factor:g}" for v in match[1].split()) + '"'

    text = re.sub(r'xyz="([^"]*)"', scaled_xyz, text)
    return text.replace('lower="0" upper="0.2"', f'lower="0" upper="{0.2 * factor:g}"')


@pytest.mark.parametrize("factor, unit", [(1.0, "m"), (100.0, "cm"), (1000.0, "mm")])
def test_info_names_the_unit_a_urdf_is_written_in(tmp_path, capsys, factor, unit):
    path = tmp_path / "scara.urdf"
    path.write_text(_scaled(SCARA, factor))
    assert main(["info", str(path)]) == 0
    line = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("lengths in"))
    assert line.startswith(f"lengths in {unit}:"), line
    assert ("robot's size" in line) == (factor != 1.0)


def test_a_millimetre_urdf_solves_to_a_millimetre_by_default(tmp_path, capsys):
    path = tmp_path / "scara_mm.urdf"
    path.write_text(_scaled(SCARA, 1000.0))
    sk = deik.read_urdf(path, "base", "tcp")
    rng = np.random.default_rng(3)
    for seed in range(3):
        q = rng.uniform(sk.lower, sk.upper)
        target = deik.forward_kinematics(sk, q).position("tcp")
        out = tmp_path / f"pose{seed}.json"
        argv = ["solve", str(path), "--tip", "tcp", "--reach", "tcp", *map(str, target), "--seed", str(seed)]
        assert main([*argv, "--out", str(out), "--quiet"]) == 0
        printed = capsys.readouterr().out
        assert re.search(r"position tcp .* mm +1 mm +yes", printed), printed
        answer = np.array(json.loads(out.read_text())["angles"], float).reshape(-1)
        reached = deik.forward_kinematics(sk, answer).position("tcp")
        assert np.linalg.norm(reached - target) <= 1.0  # millimetres


def test_a_goal_on_a_link_the_tip_cut_away_names_the_flag_that_keeps_it(tmp_path, capsys):
    path = tmp_path / "scara.urdf"
    path.write_text(SCARA)
    assert main(["solve", str(path), "--tip", "quill", "--reach", "tcp", "0.5", "0.2", "0.2"]) == 2
    err = capsys.readouterr().err.strip()
    expected = f"deik: error: 'tcp' is a link of {path} but not on the chain --tip quill keeps: add --tip tcp"
    assert err.splitlines() == [expected]


@pytest.mark.parametrize("scale, unit, tolerance", [(100.0, "cm", 0.1), (0.45 / 0.0254, "cmu", 0.001 * 0.45 / 0.0254)])
def test_a_bvh_walk_in_centimetres_or_cmu_solves_to_a_millimetre_by_default(tmp_path, capsys, scale, unit, tolerance):
    """The BVH counterpart (docs/conventions.md, Tolerances): the procedural walk written in
    centimetres or the CMU database's unit, a hand moved to another frame's place, is met within
    1 mm in the unit the body's size says, checked by deik's float64 forward kinematics."""
    from judging.rigs import format_rig
    from judging.walk import procedural_walk
    from tests.cleanup.test_clip_rules import _scaled

    path = tmp_path / "walk.bvh"
    path.write_text(format_rig(_scaled(procedural_walk(), scale).rig))
    clip = deik.read_bvh(path)
    target = deik.forward_kinematics(clip.skeleton, clip.pose(12)).position("LeftElbow_end")
    out = tmp_path / "pose.json"
    argv = ["solve", str(path), "--frame", "4", "--reach", "LeftElbow_end", *map(str, target), "--seed", "1"]
    assert main([*argv, "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert re.search(rf"position LeftElbow_end .* {unit} +{tolerance:.6g} {unit} +yes", printed), printed
    answer = np.array(json.loads(out.read_text())["angles"], float).reshape(-1)
    reached = deik.forward_kinematics(clip.skeleton, answer).position("LeftElbow_end")
    assert np.linalg.norm(reached - target) <= tolerance
