"""A retarget from a clip made with Z up (issue 27, "any rig"): the procedural walk
(judging/walk.py) turned whole so that Z is up (tests/cleanup/test_clip_up.py) is
refused by `deik retarget` with one line naming `--up 0 0 1`, and with it lands on the humanoid
and on a URDF as the Y-up walk does (a map's rotation is written for a Y-up source, and a source
read with another up is turned upright first), and its legs lengthen on its own rig as the Y-up
walk's do."""

import numpy as np
import pytest

import deik
from deik.cli import main
from helpers import ROOT
from judging.rigs import format_rig, parse_rig, pose_points
from tests.cleanup.test_clip_any_rig import sunk_walk
from tests.cleanup.test_clip_up import TO_Y, TO_Z, turned

HUMANOID_MAP = ROOT / "examples/maps/shared_bvh_to_humanoid.toml"


@pytest.fixture(scope="module")
def walks(tmp_path_factory):
    folder = tmp_path_factory.mktemp("retarget_up")
    rig = sunk_walk().rig
    paths = {"y_up": folder / "y_up.bvh", "z_up": folder / "z_up.bvh"}
    paths["y_up"].write_text(format_rig(rig))
    paths["z_up"].write_text(format_rig(turned(rig, TO_Z)))
    return paths


def test_a_source_made_with_z_up_is_refused_naming_the_up(walks, tmp_path, capsys):
    out = tmp_path / "out.bvh"
    argv = ["retarget", str(walks["z_up"]), "--map", str(HUMANOID_MAP), "--to", "humanoid", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"deik: error: {walks['z_up']}: ")
    assert "so that is not its up direction; it rests along 0 0 1: give --up 0 0 1" in err and not out.exists()


def test_with_its_up_it_lands_on_the_humanoid_as_the_y_up_source_does(walks):
    plain = deik.retarget(deik.read_bvh(walks["y_up"]), "humanoid", joint_map=HUMANOID_MAP)
    upright = deik.retarget(deik.read_bvh(walks["z_up"], up=(0, 0, 1)), "humanoid", joint_map=HUMANOID_MAP)
    np.testing.assert_allclose(upright.motion.frames, plain.motion.frames, atol=1e-6)
    measures = {key: value for key, value in plain.report["summary"].items() if "time" not in key}  # not timings
    assert {key: upright.report["summary"][key] for key in measures} == pytest.approx(measures, rel=1e-6, abs=1e-9)


def test_the_command_takes_up_for_the_source(walks, tmp_path, capsys):
    written = {}
    for name, flags in (("y_up", []), ("z_up", ["--up", "0", "0", "1"])):
        out = tmp_path / f"{name}.bvh"
        argv = ["retarget", str(walks[name]), *flags, "--map", str(HUMANOID_MAP), "--to", "humanoid", "--out", str(out)]
        assert main(argv) == 0, capsys.readouterr().err
        written[name] = deik.read_bvh(out).frames
    np.testing.assert_allclose(written["z_up"], written["y_up"], atol=1e-5)


def test_longer_legs_on_the_z_up_rig_are_the_y_up_rig_s_turned(walks, tmp_path, capsys):
    """The same-rig retarget scales the root's path whatever the order of its position channels
    (turned whole, the root's are X, Z, Y): it once needed X, Y, Z."""
    points = {}
    for name, flags in (("y_up", []), ("z_up", ["--up", "0", "0", "1"])):
        out = tmp_path / f"{name}_legs.bvh"
        argv = ["retarget", str(walks[name]), *flags, "--scale", "LeftHip=1.1,RightHip=1.1", "--out", str(out)]
        assert main(argv) == 0, capsys.readouterr().err
        rig = parse_rig(out.read_text())
        points[name] = pose_points(rig if name == "y_up" else turned(rig, TO_Y))
    np.testing.assert_allclose(points["z_up"], points["y_up"], atol=1e-6)
