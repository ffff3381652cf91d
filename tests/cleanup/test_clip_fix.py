"""fix_clip and `deik clip` on the real clips: planted feet stop sliding while the pose stays
close to the performance; bad input is refused before anything is written."""

import json

import numpy as np
import pytest

import deik
from deik.cleanup.clip_goals import ClipGoals, Reach, neighbour_displacement
from deik.cleanup.contacts import contacts_from_ranges, detect_contacts, foot_sites
from deik.cleanup.fix import fix_clip
from deik.cleanup.metrics import foot_sliding, joint_deviation, velocity_spikes
from deik.cli.app import main
from deik.io.bvh import Clip, read_bvh
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, euler, translation
from deik.model.kinematics import forward_kinematics
from helpers import shared_path


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["walk", "run"])
def test_planted_feet_stop_sliding_and_the_pose_stays_close(name):
    clip = read_bvh(shared_path("humanoid", f"humanoid3d_{name}.bvh"))
    contacts = detect_contacts(clip, foot_sites(clip.skeleton))
    fix = fix_clip(clip, ClipGoals(contacts), seed=0)
    before, after = foot_sliding(clip, contacts), foot_sliding(fix.clip, contacts)
    assert np.nanmean(before) > 1e-3  # the captured feet really slide (metres per frame, along the ground)
    assert np.nanmean(after) < 1e-3
    mean_deviation, _ = joint_deviation(clip, fix.clip)
    assert mean_deviation.mean() < 5.0
    # the fixed clip keeps the input's layout and frame time
    assert fix.clip.layout == clip.layout and fix.clip.frame_time == clip.frame_time


@pytest.mark.shared_data
@pytest.mark.parametrize("seed", [0, 1])
def test_jump_hand_touches_a_prop_at_the_apex_without_new_spikes(seed):
    """A reach eased in and out over 8 frames at 60 Hz: no velocity or acceleration peak more than
    10 % above the capture's."""
    clip = read_bvh(shared_path("humanoid", "humanoid3d_jump.bvh"))
    hand, first, last = "RightElbow_end", 55, 65  # the apex: hips and hands highest at frame 60
    path = forward_kinematics(clip.skeleton, clip.frames).position(hand)
    prop = path[first : last + 1].mean(axis=0) + 0.05 * clip.skeleton.up  # 5 cm above the path
    mask = np.zeros(clip.n_frames, bool)
    mask[first : last + 1] = True
    targets = np.where(mask[:, None], prop, np.nan)
    before = np.linalg.norm(path - prop, axis=-1)[mask]
    assert before.min() > 0.035 and before.max() > 0.09  # the performance misses the prop
    contacts = detect_contacts(clip)
    fix = fix_clip(clip, ClipGoals(contacts, (Reach(hand, mask, targets),)), seed=seed)
    reached = forward_kinematics(clip.skeleton, fix.clip.frames).position(hand)
    assert np.linalg.norm(reached - prop, axis=-1)[mask].max() < 0.01
    original, fixed = velocity_spikes(clip), velocity_spikes(fix.clip)
    for key in ("max_dof_velocity", "max_dof_acceleration", "max_position_acceleration"):
        assert fixed[key] <= 1.1 * original[key], key
    assert np.nanmax(foot_sliding(fix.clip, contacts)) < 1e-3  # the feet stay planted
    assert fix.met.all()


def test_de_repairs_only_the_frames_the_warm_start_leaves_unmet(tmp_path):
    """Self-collision is DE's alone: the warm start leaves the frames whose hand is in the chest
    unmet, and the first DE pass searches exactly those; a repair that would make a point jolt is
    refused and its frame stays as it was, listed unmet."""
    h = deik.humanoid()
    rest = deik.forward_kinematics(h, h.reference)
    chest = rest.position("chest") + [0.0, 0.0, 0.03]
    pelvis = [deik.Position("pelvis", rest.position("pelvis")), deik.Orientation("pelvis", np.eye(3))]
    reach = deik.Problem(h, [*pelvis, deik.Position("left_hand", chest)])
    through = deik.solve(reach, population=64, generations=300, restarts=2, seed=1, dtype="float64").angles
    # from the rest pose (the hand clear of the body) to nearly `through`: however the solve
    # reaches the chest, the first frames are met and the last are not
    poses = h.reference + np.linspace(0.0, 0.95, 6)[:, None] * (through - h.reference)
    deik.write_bvh(tmp_path / "through.bvh", Clip.from_poses(h, poses, 1.0 / 30.0))
    clip = read_bvh(tmp_path / "through.bvh")  # as `deik clip` reads it: capsules from the bone lengths
    goals = ClipGoals(self_collision=0.0)
    warm = fix_clip(clip, goals, passes=0)
    assert warm.passes == 0 and 0 < (~warm.met).sum() < clip.n_frames
    fix = fix_clip(clip, goals, population=48, generations=200, seed=0)
    stage = fix.stages[1]
    assert stage["frames"] == (~warm.met).sum() and stage["evaluations"] > 0
    assert fix.met.sum() + stage["refused"] >= clip.n_frames - (fix.passes - 1) * clip.n_frames  # kept ones met
    assert (fix.met >= warm.met).all()


def test_the_fixed_clip_keeps_its_euler_channels_continuous_across_a_wrap():
    joints = [
        Joint("body", None, dofs=translation("XYZ", -1.0, 1.0), mass=1.0),
        Joint("arm", "body", (0.0, 1.0, 0.0), dofs=euler("ZXY"), mass=1.0),
    ]
    sk = build_skeleton(joints, [Site("foot", "body"), Site("hand", "arm", (1.0, 0.0, 0.0))])
    poses = np.zeros((12, 6))
    poses[:, 0] = np.linspace(0.0, 0.011, 12)  # the planted foot slides 1 mm a frame
    turn = np.radians(np.linspace(160.0, 215.0, 12))
    poses[:, 3] = (turn + np.pi) % (2 * np.pi) - np.pi  # the arm's Z channel jumps from 175 to -175
    clip = Clip.from_poses(sk, poses, 1 / 30)
    fix = fix_clip(clip, ClipGoals(contacts_from_ranges(clip, {"foot": [(0, 12)]})), seed=0)
    arm = np.degrees(fix.clip.frames[:, 3:])
    assert np.abs(np.diff(arm, axis=0)).max() < 5.1  # 5 degrees a frame as performed, no 360
    before, after = (forward_kinematics(sk, c.frames).R_world_frame for c in (clip, fix.clip))
    np.testing.assert_allclose(after[:, 1], before[:, 1], atol=1e-6)  # the arm turns as captured
    assert np.nanmax(foot_sliding(fix.clip, contacts_from_ranges(clip, {"foot": [(0, 12)]}))) < 1e-3


def test_neighbour_displacement_is_the_mean_of_both_sides():
    d = np.arange(10.0).reshape(5, 2) ** 2
    out = neighbour_displacement(d)
    np.testing.assert_allclose(out[2], (d[1] + d[3]) / 2)
    np.testing.assert_allclose(out[0], d[1])
    np.testing.assert_allclose(out[-1], d[-2])


def test_clip_goals_refuse_impossible_settings():
    with pytest.raises(ValueError, match="nothing to fix"):
        ClipGoals()
    with pytest.raises(ValueError, match="balance needs contacts"):
        ClipGoals(balance=True)


TRACKS = {
    "good.csv": "frame,x,y,z\n3,0,1,0\n",
    "no_z.csv": "frame,x,y\n1,0,1\n",
    "late.csv": "frame,x,y,z\n3,0,1,0\n40,0,1,0\n",
    "no_z.json": '[{"frame": 1, "x": 0, "y": 1}]',
}


@pytest.mark.shared_data
@pytest.mark.parametrize(
    "extra,fragment",
    [
        (["--reach", "NoSuchHand=0,1,0@3:5"], "--reach 'NoSuchHand=0,1,0@3:5': no joint or site 'NoSuchHand'"),
        (["--reach", "LeftElbow_ned={tmp}/good.csv"], "did you mean 'LeftElbow_end'"),
        (["--reach", "NoSuchHand={tmp}/good.csv"], "its sites are RightAnkle_end, LeftAnkle_end, Neck_end"),
        (["--plant-feet", "LeftAnkel:1-3"], "no joint or site 'LeftAnkel' in humanoid3d_walk.bvh; did you mean"),
        (
            ["--reach", "LeftElbow_end=0,1,0@30:60"],
            "frames 30:60 are outside the clip or reversed; valid frames: 0..38",
        ),
        (["--reach", "LeftElbow_end={tmp}/late.csv"], "late.csv:3: frame 40 is outside the clip; valid frames: 0..38"),
        (["--plant-feet", "LeftAnkle_end:30-45"], "frames 30-45 are outside the clip or reversed; valid frames: 0..38"),
        (
            ["--reach", "LeftElbow_end={tmp}/no_z.csv"],
            "no_z.csv:1: missing column z: the header must name frame, x, y and z",
        ),
        (
            ["--reach", "LeftElbow_end={tmp}/no_z.json"],
            'no_z.json: [0]: missing z: each element needs "frame", "x", "y" and "z"',
        ),
        (["--plant-feet", "auto", "--plant-feet", "LeftAnkle:1-3"], "cannot be combined"),
        (["--plant-feet", "none", "--plant-feet", "LeftAnkle:1-3"], "--plant-feet none cannot be combined"),
        (["--fidelity", "3"], "argument --fidelity: '3' is out of range: give a finite number from 0 to 1"),
        (["--floor", "-1e300"], "--floor '-1e300': use a height (a finite number of length units, within +-1e12)"),
        (["--passes", "1000000000"], "--passes 1000000000: give a whole number from 0 to 1000"),
        (
            ["--population", "10000000", "--balance", "--quiet"],
            "a clip fix of 39 frames x population 10000000 needs about",
        ),
        (["--contact-speed", "inf"], "argument --contact-speed: 'inf' is out of range"),
        (
            ["--contact-speed", "0"],
            "argument --contact-speed: '0' is out of range: give a finite number above 0 to 1e+12",
        ),
        (["--memory-limit", "inf"], "argument --memory-limit: 'inf' is out of range"),
        (["--contact", "LeftKnee-Hips@1-3"], "--contact 'LeftKnee-Hips@1-3' (a joint, an end site or a bone"),
        (["--contact", "LeftKnee@3-1"], "frames 3-1 are outside the clip or reversed; valid frames: 0..38"),
        (["--contact", "auto", "--contact", "none"], "--contact none cannot be combined"),
        (
            ["--floor", "low"],
            "--floor 'low': use a height (a finite number of length units, within +-1e12), auto or none",
        ),
    ],
)
def test_clip_cli_mistakes_exit_2_and_write_nothing(tmp_path, capsys, extra, fragment):
    for name, text in TRACKS.items():
        (tmp_path / name).write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    (out / "fixed.bvh").write_text("an earlier result")
    argv = [
        "clip",
        str(shared_path("humanoid", "humanoid3d_walk.bvh")),
        "--out",
        str(out / "fixed.bvh"),
        "--report",
        str(out / "report.png"),
        "--json",
        str(out / "report.json"),
    ]
    assert main(argv + [e.format(tmp=tmp_path) for e in extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err, err
    assert [p.name for p in out.iterdir()] == ["fixed.bvh"]  # no report, no temporary file left
    assert (out / "fixed.bvh").read_text() == "an earlier result"


@pytest.mark.shared_data
def test_clip_cli_contacts_anywhere_floor_and_an_unreachable_reach(tmp_path, capsys):
    argv = ["clip", str(shared_path("humanoid", "humanoid3d_walk.bvh")), "--out", str(tmp_path / "fixed.bvh")]
    argv += ["--json", str(tmp_path / "report.json"), "--plant-feet", "none", "--contact", "auto"]
    argv += ["--contact", "LeftElbow-LeftElbow_end@20-22", "--floor", "0.005"]
    argv += ["--reach", "RightElbow_end=3,1,0@10:12"]  # 3 m ahead: out of reach of a planted body
    assert main(argv) == 0, capsys.readouterr().err
    captured = capsys.readouterr()
    assert "floor at 0.005 m (given)" in captured.out
    assert "reach_RightElbow_end: out of reach in" in captured.out
    data = json.loads((tmp_path / "report.json").read_text())
    assert data["floor"] == {"height": 0.005, "how": "given", "resting_contacts_height": None, "kept": True}
    assert data["balance"] is None  # no --balance
    assert {10, 11, 12} <= set(data["reach_unreached"]["reach_RightElbow_end"]["frames"])
    sites = {site["site"]: site["contacts"] for site in data["contacts"]["sites"]}
    # the forearm hangs: its lowest end, the wrist, takes the contact given on the bone
    assert [(c["first_frame"], c["last_frame"]) for c in sites["LeftElbow_end"]] == [(20, 22)]
    assert "RightAnkle_end" not in sites and "RightKnee" not in sites  # --plant-feet none; no knee rests
    met = np.array(data["met_per_frame"])
    depth = np.array(data["per_frame"]["penetration_mm"]["after"], float)
    # the feet rest in the capture but are not planted (--plant-feet none): where they slide the
    # frame is listed as unmet even though its goals are met
    sliding = np.isin(np.arange(len(met)), data["sliding_frames"])
    assert set(data["resting_points"]) >= {"RightAnkle_heel", "LeftAnkle_toe"}
    assert sliding.any() and not (met & sliding).any()
    assert (met | sliding).sum() >= 20 and np.nanmax(depth[met]) <= 1.0  # the body's surface, where met


@pytest.mark.shared_data
def test_clip_cli_writes_clip_report_and_json(tmp_path, capsys):
    out = tmp_path / "fixed.bvh"
    argv = [
        "clip",
        str(shared_path("humanoid", "humanoid3d_run.bvh")),
        "--out",
        str(out),
        "--report",
        str(tmp_path / "report.png"),
        "--json",
        str(tmp_path / "report.json"),
        "--passes",
        "1",
        "--balance",
    ]
    assert main(argv + ["--progress"]) == 0, capsys.readouterr().err
    captured = capsys.readouterr()
    assert "contacts (detected)" in captured.err and "deik clip: " in captured.err  # the notes, the bar
    assert "sliding of the resting points mean" in captured.out and "coherence: how far" in captured.out
    assert "floor at 0 m (the file's ground plane" in captured.out
    assert read_bvh(out).n_frames == 25
    assert (tmp_path / "report.png").stat().st_size > 0
    data = json.loads((tmp_path / "report.json").read_text())
    assert data["length_unit"] == "m" and data["frames"] == 25
    metric = data["metrics"]["penetration_max_mm"]
    assert metric["unit"] == "mm" and metric["after"] >= 0.0
    assert 0.0 <= data["metrics"]["foot_skating_ratio_share"]["after"] <= 1.0
    keys = [goal["key"] for goal in data["goals"]]
    assert len(keys) == len(set(keys)) and keys[-2:] == ["fidelity", "coherence"]
    assert all(len(goal["after"]) == 25 for goal in data["goals"])
    assert all(len(entry["after"]) == 25 for entry in data["per_frame"].values())
    contacts = data["contacts"]
    assert len(contacts["count_per_frame"]) == 25 and contacts["detected"]
    plant = contacts["sites"][0]["contacts"][0]
    assert plant["first_frame"] <= plant["last_frame"] and len(plant["plant"]) == 3
    far = data["joints_far_from_capture"]
    assert far["threshold_deg"] == 30.0 and all(d["deviation_deg"] > 30.0 for d in far["joint_frames"])
    assert sum(far["count_per_frame"]) == len(far["joint_frames"])
    balance = data["balance"]
    assert balance["balanced_frames"] and not set(balance["balanced_frames"]) & set(balance["skipped_frames"])
    assert balance["acceleration_budget_m_per_s2"] > 0 and len(balance["shift_mm"]) == 25
    dynamics = data["dynamics"]
    assert dynamics["peak_ratio_limit"] == 1.1 and dynamics["peaks_kept"]
    assert dynamics["worst_point"]["ratio"] <= 1.1 and len(dynamics["point_acceleration_ratios"]) == 18
    assert set(dynamics["peak_ratios"]) == {
        "dof_velocity",
        "dof_acceleration",
        "position_velocity",
        "position_acceleration",
    }
    assert "balance: ZMP over the support in" in captured.out and "peaks against the capture's, kept" in captured.out
    assert main(argv + ["--quiet", "--overwrite"]) == 0
    quiet = capsys.readouterr()
    # --quiet: no bar and no notes; warnings (joints far from the capture) still print
    assert all(line.startswith("warning: ") for line in quiet.err.splitlines())
    assert "sliding of the resting points mean" in quiet.out and "coherence: how far" not in quiet.out


def _cut(clip, frames: int):
    return Clip(clip.skeleton, clip.frames[:frames], clip.frame_time, clip.layout, clip.source, clip.mass_source)


@pytest.mark.shared_data
@pytest.mark.parametrize("frames", [1, 2, 3, 4, 5])
def test_balance_on_a_clip_of_a_few_frames_is_fixed_and_reported_without_nan(tmp_path, capsys, frames):
    from deik.io.bvh import write_bvh

    path = tmp_path / "short.bvh"
    write_bvh(path, _cut(read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh")), frames))
    assert main(["clip", str(path), "--balance", "--out", str(tmp_path / "fixed.bvh"), "--quiet"]) == 0
    printed = capsys.readouterr()
    assert "nan" not in printed.out and printed.err == ""  # an acceleration of 2 frames is "-", not nan
    assert read_bvh(tmp_path / "fixed.bvh").n_frames == frames


def test_a_clip_without_channels_is_refused_with_the_reason(tmp_path, capsys):
    path = tmp_path / "still.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  JOINT LeftFoot\n  {\n    OFFSET 0 -1 0\n    End Site\n"
        "    {\n      OFFSET 0 -0.1 0\n    }\n  }\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333\n"
    )
    assert main(["clip", str(path), "--out", str(tmp_path / "fixed.bvh"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err == f"deik: error: {path}: the clip has no channels: no joint moves, nothing to fix\n"


@pytest.mark.shared_data
def test_the_time_limit_bounds_the_passes_of_a_fix_that_cannot_succeed():
    clip = _cut(read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh")), 10)
    mask, hand = np.ones(clip.n_frames, bool), "RightElbow_end"
    path = forward_kinematics(clip.skeleton, clip.frames).position(hand)
    apart = [Reach(hand, mask, path + side * 0.2 * clip.skeleton.up) for side in (1, -1)]  # never both met
    goals = ClipGoals(None, tuple(apart))
    fix = fix_clip(clip, goals, passes=1000, generations=10**6, patience=10**6, time_limit=1.0)
    assert not fix.met.any() and fix.passes < 10  # a pass of a million generations each, cut by the limit
    assert fix.wall_time < 60
