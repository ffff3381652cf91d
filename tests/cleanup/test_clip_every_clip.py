"""Every shared clip cleaned with no flags (issues 17 and 27): every resting point planted, the
body kept out of the floor and no point made to jolt, or the frame listed; what no goal touches
keeps the capture and the Euler channels stay continuous; a reach changes nothing outside its
eased window; the standard metrics reach the summary, the JSON and the report picture.
benchmarks/clip_targets.py measures every clip with an independent judge."""

import dataclasses
import json

import numpy as np
import pytest

from deik.cleanup.clip_goals import ClipGoals, Reach
from deik.cleanup.dynamics import PEAK_RATIO, peak_ratios, point_acceleration_ratios
from deik.cleanup.fix import fix_clip
from deik.cleanup.ground import resting_body
from deik.cleanup.metrics import joint_angles, turning_joint_names
from deik.cleanup.summary import clip_report
from deik.cli.app import main
from deik.io.bvh import read_bvh, write_bvh
from deik.model.kinematics import forward_kinematics
from helpers import shared_path

CLIPS = ("walk", "run", "jump", "crawl", "getup_facedown", "kick", "punch", "dance_a")


def humanoid(name, frames=0):
    path = shared_path("humanoid", f"humanoid3d_{name}.bvh")
    clip = read_bvh(path, segments=str(path).replace(".bvh", ".segments.json"))
    return dataclasses.replace(clip, frames=clip.frames[:frames]) if frames else clip


def cleaned(clip, reach=()):
    """(fix, contacts) of `clip` as `deik clip` fixes it with no flags."""
    body, floor, contacts = resting_body(clip)
    return fix_clip(clip, ClipGoals(contacts, reach, floor=floor.height), seed=0, body=body), contacts


@pytest.mark.shared_data
@pytest.mark.parametrize("name", CLIPS)
def test_every_clip_keeps_its_contacts_off_the_floor_slide_and_jolts(name):
    """The floor is the capture's ground plane; in every frame that meets its goals (most of them)
    the planted points slide at most 1 mm a frame (issue 27's bound; a planted heel that rises as
    the foot rolls comes nearer its planted toe, plants.linked_at_heights: the dance's 0.95 mm,
    0.5 mm before) and the body's surface stays above the
    floor; no joint or end site accelerates beyond 1.1 times its own peak in the capture and no
    rotation channel beyond its peak, in any frame; no Euler channel jumps."""
    clip = humanoid(name)
    fix, contacts = cleaned(clip)
    assert fix.goals.floor == 0.0
    met = fix.met
    assert met.mean() >= 0.5, f"{met.sum()} of {clip.n_frames} frames met"
    before, after = fix.on_body()
    report = clip_report(before, after, dataclasses.replace(contacts, mask=contacts.mask & met[:, None]))
    assert not report["sliding_max_mm_per_frame"]["after"] > 1.0  # NaN: no contact step in a met frame
    surface = forward_kinematics(after.skeleton, after.frames).p_world_frame @ clip.skeleton.up - fix.body.radius
    assert surface[met].min() >= fix.goals.floor - 1e-3
    own = np.arange(after.skeleton.n_frames) < clip.skeleton.n_frames
    ratios = point_acceleration_ratios(before, after, fix.body.part & own)
    assert np.nanmax(ratios) <= PEAK_RATIO + 1e-6
    for measure, ratio in peak_ratios(clip, fix.clip).items():
        assert measure.startswith("position") or ratio <= PEAK_RATIO, measure
    steps = np.abs(np.diff(fix.clip.frames, axis=0))
    assert steps.max() <= np.abs(np.diff(clip.frames, axis=0)).max() + np.radians(10.0)


@pytest.mark.shared_data
def test_joints_and_frames_no_goal_touches_keep_the_capture():
    """Item 2: with the feet planted, the chest, neck and arms serve no goal and keep the
    capture exactly; in the jump's flight a correction fades, and frames 12 or more frames from
    any contact (0.2 s) are within 2 degrees of the capture."""
    clip = humanoid("jump")
    fix, contacts = cleaned(clip)
    angles = joint_angles(clip, fix.clip)
    names = turning_joint_names(clip.skeleton)
    idle = [k for k, name in enumerate(names) if name in ("Chest", "Neck") or name.endswith(("Shoulder", "Elbow"))]
    assert len(idle) == 6 and np.abs(angles[:, idle]).max() < 1e-9
    touching = np.flatnonzero(contacts.mask.any(axis=1))
    far = np.array([np.abs(touching - n).min() >= 12 for n in range(clip.n_frames)])
    assert far.sum() >= 5  # the flight is long enough to have such frames
    assert angles[far].max() <= 2.0


@pytest.mark.shared_data
def test_a_reach_eases_back_to_the_performance_within_its_window():
    """Item 4: a hand reaching 10-20 cm away over frames 10-14 of the walk meets its target and
    keeps the feet planted; outside its window, eased in and out over 8 frames, the fix is the
    same as without the reach."""
    clip = humanoid("walk")
    path = forward_kinematics(clip.skeleton, clip.frames).position("RightElbow_end")
    mask = np.zeros(clip.n_frames, bool)
    mask[10:15] = True
    targets = np.where(mask[:, None], path[10:15].mean(axis=0) + [0.1, 0.15, 0.1], np.nan)
    alone, _ = cleaned(clip)
    reaching, _ = cleaned(clip, (Reach("RightElbow_end", mask, targets),))
    reached = forward_kinematics(clip.skeleton, reaching.clip.frames).position("RightElbow_end")
    assert np.linalg.norm(reached - targets, axis=-1)[mask].max() < 0.006
    outside = np.ones(clip.n_frames, bool)
    outside[10 - 8 : 15 + 8] = False
    assert joint_angles(alone.clip, reaching.clip)[outside].max() < 1e-6
    assert joint_angles(alone.clip, reaching.clip)[~outside].max() > 5.0  # the reach did move the body


@pytest.mark.shared_data
def test_the_standard_metrics_reach_the_summary_the_json_and_the_picture(tmp_path, capsys, monkeypatch):
    """Item 5 on the crawl's first 40 frames (hands, elbows and knees in contact): the foot-skating
    ratio, penetration (max and mean), floating, jerk, deviation from the capture and the
    contacts per frame, under machine keys with units, in the summary and the JSON; the report
    picture's notes carry them and its series the contacts per frame."""
    import deik.viz.clip_report as clip_report_module

    drawn = {}
    real = clip_report_module.plot_clip_report

    def record(series, path, frame_time, title="", notes=(), pose=None):
        drawn.update(series=series, notes=list(notes))
        real(series, path, frame_time, title, notes, pose)

    monkeypatch.setattr(clip_report_module, "plot_clip_report", record)
    source = tmp_path / "crawl.bvh"
    write_bvh(source, humanoid("crawl", 40))
    argv = ["clip", str(source), "--out", str(tmp_path / "out.bvh")]
    argv += ["--json", str(tmp_path / "out.json"), "--report", str(tmp_path / "out.png"), "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "out.json").read_text())
    keys = (
        "foot_skating_ratio_share",
        "penetration_max_mm",
        "penetration_mean_mm",
        "floating_max_mm",
        "jerk_mean_m_per_s3",
        "joint_angle_deviation_max_deg",
        "joint_position_deviation_mean_mm",
        "contacts_per_frame_mean_count",
    )
    for key in keys:
        metric = data["metrics"][key]
        assert metric["unit"] and np.isfinite(metric["after"]), key
        assert metric["label"] in out, key
    assert len(data["per_frame"]["contacts_count"]["after"]) == 40
    assert "peaks against the capture's" in out and data["dynamics"]["peaks_kept"]
    notes = "\n".join(drawn["notes"])
    for label in ("foot-skating ratio", "penetration below the floor max", "floating in contact max", "jerk mean"):
        assert label in notes, label
    assert "joint angle from the capture max" in notes and "peaks against the capture's" in notes
    assert "sites in contact (count)" in drawn["series"]
