"""Balance that keeps the motion's dynamics: the support's half-planes and the zero-moment point
against independent computations, a COM track on a hand-made body whose answer is known, the
COM Jacobian against finite differences, and the real clips balanced without new jolts."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from deik.cleanup.balance import SOLE, balance_track, support_halfplanes, zero_moment_point, zmp_outside_support
from deik.cleanup.clip_goals import ClipGoals
from deik.cleanup.contacts import contacts_from_ranges
from deik.cleanup.dynamics import PEAK_RATIO, point_acceleration_ratios
from deik.cleanup.fix import fix_clip
from deik.cleanup.ground import resting_body
from deik.cleanup.plants import planted_targets
from deik.cleanup.warmstart import position_jacobian
from deik.io.bvh import Clip, read_bvh, write_bvh
from deik.model.build import build_skeleton
from deik.model.geometry import ground_frame, polygon_distance
from deik.model.joints import Joint, Site, translation
from deik.model.kinematics import forward_kinematics
from helpers import shared_path


@pytest.mark.parametrize("count", [1, 2, 3, 4, 6])
def test_support_halfplanes_hold_the_grown_hull(count):
    """Every point within `radius` of the hull satisfies the half-planes, none beyond 1.1 radius."""
    rng = np.random.default_rng(count)
    radius = 0.05
    for _ in range(20):
        points = rng.uniform(-0.3, 0.3, (count, 2))
        if count == 3 and _ % 2:
            points[2] = 0.3 * points[0] + 0.7 * points[1]  # collinear: a segment
        A, b = support_halfplanes(points, radius)
        q = rng.uniform(-0.6, 0.6, (400, 2))
        distance = polygon_distance(q, np.broadcast_to(points, (len(q),) + points.shape))
        inside = (q @ A.T <= b + 1e-12).all(axis=1)
        assert inside[distance <= radius].all()
        assert not inside[distance > 1.1 * radius].any()


def test_zero_moment_point_of_a_steady_push_and_of_free_fall():
    dt, g, h = 0.02, 9.81, 0.9
    up = np.array([0.0, 1.0, 0.0])
    t = np.arange(30) * dt
    com = np.zeros((30, 3))
    com[:, 0] = 0.5 * 2.0 * t**2  # 2 m/s^2 along X at a steady height
    com[:, 1] = h
    zmp, lever, falling = zero_moment_point(com, up, 0.0, dt, g)
    inner = slice(6, -6)  # the path is smoothed (over 4 standard deviations) before it is differenced
    np.testing.assert_allclose(lever[inner], h / g)
    axes = ground_frame(up)[:2]
    expected = (com - [h * 2.0 / g, 0.0, 0.0]) @ axes.T  # the ZMP trails the COM by h a / g
    np.testing.assert_allclose(zmp[inner], expected[inner], atol=1e-9)
    assert not falling.any()
    com[:, 1] = h - 0.5 * g * t**2  # dropped: no ZMP
    zmp, _, falling = zero_moment_point(com, up, 0.0, dt, g)
    assert falling[inner].all() and np.isnan(zmp[inner]).all()


def sway(lean, frame_time=1 / 30) -> Clip:
    """A body (its mass at the root, 1 m above the floor, Y up) standing on a foot joint kept at
    the origin while the root leans sideways by `lean` (N,) metres."""
    joints = [
        Joint("root", None, dofs=translation("XYZ", -0.5, 0.5), mass=1.0),
        Joint("foot", "root", dofs=translation("XYZ", -0.5, 0.5)),
    ]
    poses = np.zeros((len(lean), 6))
    poses[:, 0], poses[:, 1] = lean, 1.0
    poses[:, 3:5] = -poses[:, 0:2]  # the foot stays at the origin
    return Clip.from_poses(build_skeleton(joints, [Site("head", "root", (0.0, 0.7, 0.0))]), poses, frame_time)


def test_a_leaning_body_is_brought_back_over_its_foot_smoothly():
    lean = np.clip(np.linspace(-0.05, 0.15, 60), 0.0, None)  # leans out to 15 cm over 1.5 s
    clip = sway(lean)
    sk = clip.skeleton
    contacts = contacts_from_ranges(clip, {"foot": [(0, 60)]})
    plants = planted_targets(clip, contacts)
    track = balance_track(clip, contacts, plants, 9.81, share=100.0)
    assert track.balanced.all() and not track.skipped.any()
    zmp, _, _ = zero_moment_point(track.track, sk.up, contacts.ground, clip.frame_time, 9.81)
    # the track's ZMP stays within the sole around the foot at the origin
    assert np.linalg.norm(zmp, axis=1).max() <= 1.1 * SOLE * sk.reach + 1e-6
    com = forward_kinematics(sk, clip.frames).p_world_com
    np.testing.assert_allclose((track.track - com) @ sk.up, 0.0, atol=1e-12)  # it moves along the ground
    assert np.linalg.norm(track.shift, axis=1).max() < 0.15  # back, not past the foot
    # a budget of a thousandth of the capture's peak cannot hold the lean: frames are skipped, the rest hold
    tight = balance_track(clip, contacts, plants, 9.81, share=1e-3)
    assert tight.skipped.any() and not (tight.skipped & tight.balanced).any()
    added = np.linalg.norm(np.diff(tight.shift, 2, axis=0), axis=1) / clip.frame_time**2
    assert added.max() <= tight.budget + 1e-9


@pytest.mark.shared_data
def test_com_jacobian_matches_finite_differences():
    clip = read_bvh(
        shared_path("humanoid", "humanoid3d_walk.bvh"),
        segments=shared_path("humanoid", "humanoid3d_walk.segments.json"),
    )
    sk, poses = clip.skeleton, clip.poses()[::13]
    x, jac = position_jacobian(sk, poses, ["Hips"], centre_of_mass=True)
    np.testing.assert_allclose(x[:, 1], forward_kinematics(sk, poses).p_world_com, atol=1e-12)
    h = 1e-6
    for d in range(sk.n_dofs):
        step = np.zeros(sk.n_dofs)
        step[d] = h
        numeric = (
            forward_kinematics(sk, poses + step).p_world_com - forward_kinematics(sk, poses - step).p_world_com
        ) / (2 * h)
        np.testing.assert_allclose(jac[:, 1, :, d], numeric, atol=1e-8)


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["walk", "run", "jump"])
def test_balanced_clip_keeps_its_dynamics(name):
    """--balance: in the frames it balances (and does not take back), the fixed clip's ZMP lies
    over the support (soles included), within three balance tolerances, far closer than the
    capture's; no point accelerates more than 1.1 times its own peak in the capture; frames it
    cannot hold are skipped, not forced."""
    path = shared_path("humanoid", f"humanoid3d_{name}.bvh")
    clip = read_bvh(path, segments=str(path).replace(".bvh", ".segments.json"))
    body, floor, contacts = resting_body(clip)
    fix = fix_clip(clip, ClipGoals(contacts, balance=True, floor=floor.height), seed=0, body=body)
    before, after = fix.on_body()
    sk = before.skeleton
    outside = [
        zmp_outside_support(forward_kinematics(sk, c.frames), sk, contacts, clip.frame_time, 9.81)
        for c in (before, after)
    ]
    balanced = fix.balance.balanced & fix.met  # the frames it balances, but those it took back to keep from jolting
    if name != "run":  # the run stands in 5 of its 25 frames, at take-off and landing
        assert balanced.sum() >= 0.3 * (contacts.mask.any(axis=1)).sum()
        assert np.nanmax(outside[1][balanced]) <= 3 * fix.goals.balance_tolerance  # the track's ZMP is smoothed
        assert np.nanmean(outside[1][balanced]) < 0.3 * np.nanmean(outside[0][balanced])
    own = np.arange(sk.n_frames) < clip.skeleton.n_frames
    assert np.nanmax(point_acceleration_ratios(before, after, fix.body.part & own)) <= PEAK_RATIO + 1e-6
    deviation = np.degrees(np.abs(fix.clip.poses() - clip.poses())).mean()
    assert deviation < 3.0


@pytest.mark.shared_data
def test_a_balanced_fix_runs_without_scipy(tmp_path):
    """SciPy is only in the test extra: `deik clip --balance` (the support hulls, the banded
    solves of the warm start and of the COM track) must run where it cannot be imported, as
    after a plain `pip install deik` (issue 19). The crawl's first 40 frames: hands and knees
    down, a support of several points."""
    clip = read_bvh(shared_path("humanoid", "humanoid3d_crawl.bvh"))
    short, out, report = tmp_path / "crawl40.bvh", tmp_path / "fixed.bvh", tmp_path / "fixed.json"
    write_bvh(short, dataclasses.replace(clip, frames=clip.frames[:40]))
    code = (
        "import sys; sys.modules['scipy'] = None\n"  # `import scipy` (and any scipy.*) now raises ImportError
        "from deik.cli.app import main\n"
        f"sys.exit(main(['clip', {str(short)!r}, '--contact', 'auto', '--balance', "
        f"'--out', {str(out)!r}, '--json', {str(report)!r}]))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    balance = json.loads(report.read_text())["balance"]
    # a track was planned over every frame (each balanced or skipped where holding it would jolt)
    assert len(balance["balanced_frames"]) + len(balance["skipped_frames"]) == len(balance["shift_mm"]) == 40
    assert read_bvh(out).n_frames == 40


def test_a_microsecond_frame_time_is_balanced_in_seconds():
    """Issue 29 item 14: at the smallest frame time a BVH may have, every acceleration dwarfs
    gravity; --balance ends in seconds (smoothing and fades no longer than the clip) and skips the
    frames it cannot hold, instead of building banded systems 200,000 frames wide."""
    lean = np.clip(np.linspace(-0.05, 0.15, 40), 0.0, None)
    clip = sway(lean, frame_time=1e-6)
    contacts = contacts_from_ranges(clip, {"foot": [(0, 40)]})
    fix = fix_clip(clip, ClipGoals(contacts, balance=True), seed=0)
    assert fix.wall_time < 60 and fix.balance is not None
    assert not (fix.balance.balanced & fix.balance.skipped).any()
