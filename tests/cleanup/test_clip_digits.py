"""Fingers and toes the capture never moves (a game rig's hands and feet) change nothing a fix
does to the body: their joints keep their rotations (coherence.hinge_channels), a toe joint that
cannot bend moves with its ankle (warmstart.rigid_bodies) and adds no floor row over the sole
(ground.clearances); a foot that ends in a toe joint, as a rig without End Sites writes it,
stands on a sole below and beyond that joint (soles.TOE_HEIGHT, TOE_REACH). Judged on the
procedural walk sunk under the floor with and without the digits transform (judging/cases.py),
by the judge's own kinematics."""

import dataclasses

import numpy as np
import pytest

import deik
from deik.cleanup.body import body_of
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.ground import clearances
from deik.cleanup.warmstart import rigid_bodies
from deik.io.bvh import parse_bvh
from deik.model.kinematics import forward_kinematics
from helpers import shared_path
from judging.cases import digits, source_case
from judging.clips import contact_points, deepest, resting
from judging.rigs import format_rig, joint_values, parse_rig
from tests.cleanup.test_clip_any_rig import sunk_walk

MM = 1e-3


def _cleaned(case, tmp_path):
    """The judge's contact points (N, K, 3) metres and deepest (N,) metres of `case` cleaned by
    the default command's API, and the cleaned rig."""
    path = tmp_path / f"{case.name}.bvh"
    path.write_text(format_rig(case.rig))
    result = deik.clean_clip(deik.read_bvh(path), deik.CleanOptions())
    out = tmp_path / f"{case.name}_out.bvh"
    deik.write_bvh(out, result.clip)
    rig = parse_rig(out.read_text(), case.rig.position_mode)
    return contact_points(case, rig)[1], deepest(case, rig), rig


def test_still_fingers_and_toes_leave_the_body_where_the_plain_rig_has_it(tmp_path):
    walk = sunk_walk()
    rich = digits(walk)
    assert len(rich.rig.names) == len(walk.rig.names) + 2 * 16 + 2
    plain_points, plain_depth, _ = _cleaned(walk, tmp_path)
    rich_points, rich_depth, rig = _cleaned(rich, tmp_path)
    assert plain_depth.max() <= 2 * MM
    assert rich_depth.max() <= 2 * MM, rich_depth.max()
    # the judge's points of the body (its shapes hang from the canonical joints) where the plain
    # rig's fix put them: the toes add nothing, the fingers only lengthen the body a little
    assert np.abs(rich_points - plain_points).max() <= 5 * MM, np.abs(rich_points - plain_points).max()
    # and no finger or toe turned
    rotations, _ = joint_values(rig)
    before, _ = joint_values(rich.rig)
    still = [j for j, name in enumerate(rig.names) if name not in walk.rig.names]
    assert np.allclose(rotations[:, still], before[:, still], atol=1e-6)


def test_a_joint_the_capture_never_turns_keeps_its_rotations_and_its_parents_body():
    rich = digits(sunk_walk())
    clip = parse_bvh(format_rig(rich.rig), "digits.bvh")
    sk = clip.skeleton
    held = hinge_channels(clip)
    digit_dofs = np.array(["_finger" in name or "_toe" in name or "_wrist" in name for name in sk.dof_names])
    assert held[digit_dofs].all()
    # the walk's own joints all turn, so none of theirs is held but a hinge's zero channels
    moving = np.ptp(clip.frames, axis=0) > 0
    assert not (held & moving).any()
    # a joint none of whose DOFs may move rides on its parent: its label is its ankle's
    bodies = dict(zip(sk.frame_names, rigid_bodies(sk, ~held)))
    assert bodies["RightAnkle_toe"] == bodies["RightAnkle"] == bodies["RightAnkle_toe_end"]
    assert bodies["RightKnee"] != bodies["RightAnkle"]
    # and while a still pose (one frame) holds nothing: it has no motion to keep
    one = dataclasses.replace(clip, frames=clip.frames[:1])
    assert not hinge_channels(one).any()


def test_a_toe_joint_adds_no_floor_row_over_the_sole():
    rich = digits(sunk_walk())
    body = body_of(parse_bvh(format_rig(rich.rig), "digits.bvh"))
    clear = dict(zip(body.skeleton.frame_names, clearances(body)))
    assert np.isnan(clear["LeftAnkle_toe"]) and np.isnan(clear["RightAnkle_toe"])
    assert clear["LeftAnkle"] > 0 and clear["LeftAnkle_heel"] == 0.0


@pytest.mark.shared_data
def test_the_shared_punch_on_a_rig_with_toes_stays_out_of_the_floor(tmp_path):
    # the punch stands 44 mm deep in its capture; with a toe joint added, the fix once rolled
    # the feet onto their sides, 29 mm under the floor and sliding 3 mm a frame
    case = digits(source_case(shared_path("humanoid", "humanoid3d_punch.bvh")))
    points, depth, rig = _cleaned(case, tmp_path)
    assert depth.max() <= 2 * MM, depth.max()
    names, before, clear = contact_points(case, case.rig)
    rest = resting(before, clear, case.rig.frame_time)
    step = np.linalg.norm(np.diff(points[..., [0, 2]], axis=0), axis=-1)
    assert step[rest[1:] & rest[:-1]].max() <= 1 * MM


def test_a_foot_that_ends_in_a_toe_joint_stands_on_a_sole_below_and_beyond_it(tmp_path):
    # a rig written without End Sites: each foot ends in its toe joint, inside the foot, and the
    # toes' 30 % of the foot beyond it are no point of the rig; the judge's foot box is all of it
    walk = digits(sunk_walk())
    bare = dataclasses.replace(walk, name="walk_bare", rig=dataclasses.replace(walk.rig, sites=()))
    body = body_of(parse_bvh(format_rig(bare.rig), "bare.bvh"))
    sk = body.skeleton
    toe_joint = sk.frame_index("RightAnkle_toe")
    standing = forward_kinematics(sk, np.zeros(sk.n_dofs)[None]).p_world_frame[0]
    sole_toe, heel = (standing[sk.frame_index(name)] for name in (body.feet[0].toe, body.feet[0].heel))
    over = standing[toe_joint] @ sk.up - sole_toe @ sk.up
    assert 0.01 < over < 0.02  # a ball of the foot under the toe joint
    assert np.linalg.norm(sole_toe - heel) > 1.2 * np.linalg.norm(standing[toe_joint] - heel)
    points, depth, _ = _cleaned(bare, tmp_path)
    assert depth.max() <= 2 * MM, depth.max()
