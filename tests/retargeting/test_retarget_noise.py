"""`deik retarget` low-passes a source that shakes at a high frame rate, as `deik clip` does
(cleanup/noise.py), judged by the benchmarks' independent measurement (judging/retargets.py)
against the source without its noise."""

import json

import pytest

from deik.cleanup.noise import LOW_PASS
from deik.cli import main
from judging.cases import noisy
from judging.retargets import judge, read_bvh_file, rig_pairing
from judging.rigs import format_rig
from judging.walk import procedural_walk


def _retargeted(source, folder, argv_extra=()):
    """(the --json report, the judge's figures against the walk without noise) of `deik retarget
    source --scale LeftHip=1.1,RightHip=1.1`."""
    out, report = folder / "out.bvh", folder / "out.json"
    argv = ["retarget", str(source), "--scale", "LeftHip=1.1,RightHip=1.1", "--out", str(out), "--json", str(report)]
    assert main([*argv, *argv_extra]) == 0
    written = json.loads(report.read_text())
    clean = read_bvh_file(folder / "truth.bvh")
    pairing = rig_pairing(clean, read_bvh_file(out), written["floor"]["height"])
    return written, judge(clean, pairing, ["LeftElbow_end"], 1000.0)


def test_a_source_shaking_at_120_fps_is_low_passed_and_its_feet_stay_planted(tmp_path, capsys, monkeypatch):
    """The procedural walk at 120 fps with 0.2 degrees of noise on every channel, 1 mm on the
    root and 12 mm under the floor, onto longer legs: kept as captured (the low-pass turned off
    here), a point's top speed is over 1.4x its scaled source's (its resting feet slid over 15 mm
    a frame too until rests carried on through the shake, cleanup/shaking.py); low-passed first,
    the summary says so, the feet slide under 1 mm a frame (2.8 with their rests' edges read on
    the filtered source, which no longer shows the shake) and no point is faster than 1.1x."""
    import deik.cleanup.clean as clean_module
    from deik.cleanup.noise import Noise

    case = noisy(procedural_walk(fps=120.0))
    source = tmp_path / "shaking.bvh"
    source.write_text(format_rig(case.rig))
    (tmp_path / "truth.bvh").write_text(format_rig(case.truth))
    written, measured = _retargeted(source, tmp_path, ["--quiet"])
    assert written["noise"]["low_pass_s"] == LOW_PASS
    assert measured["sliding_max_mm_per_frame"] <= 1.0, measured
    assert measured["speed_peak_ratio_max"] < 1.1, measured
    assert main(["retarget", str(source), "--scale", "LeftHip=1.1,RightHip=1.1", "--out", str(tmp_path / "o.bvh")]) == 0
    assert "capture noise 0.00256 m at rest: low-passed by Gaussians of up to 22 ms" in capsys.readouterr().out
    shown = clean_module.capture_noise
    monkeypatch.setattr(clean_module, "capture_noise", lambda *args: Noise(shown(*args).level, None))
    written, kept = _retargeted(source, tmp_path, ["--quiet"])
    assert written["noise"]["low_pass_s"] is None
    assert kept["speed_peak_ratio_max"] > 1.4, kept


@pytest.mark.parametrize("seed", [1, 2])
def test_other_draws_of_a_source_shaking_at_120_fps_keep_their_feet_planted(tmp_path, seed):
    """The procedural walk at 120 fps with other draws of that noise, onto longer legs: resting
    points slide under 1 mm a frame (2.3 and 2.0 with the rests' edges read on the filtered
    source)."""
    case = noisy(procedural_walk(fps=120.0), seed=seed)
    source = tmp_path / "shaking.bvh"
    source.write_text(format_rig(case.rig))
    (tmp_path / "truth.bvh").write_text(format_rig(case.truth))
    _, measured = _retargeted(source, tmp_path, ["--quiet"])
    assert measured["sliding_max_mm_per_frame"] <= 1.0, measured


def test_a_foot_resting_from_the_first_frame_of_a_shaking_source_rests_there_too():
    """A one-sided difference at a clip's end doubles the jitter of the point's speed: shaken by
    +-4 mm a frame (alternating, so every central difference inside is 0), the first frame of
    the procedural walk read 0.24 m/s and its stance foot was planted from the second frame
    only. The ends take their neighbours' slowness (cleanup.ground.ends_as_neighbours)."""
    import numpy as np

    from deik.io.bvh import parse_bvh
    from deik.retargeting.keypoints import stature
    from deik.retargeting.resting import rest_floor, resting_contacts

    clip = parse_bvh(format_rig(procedural_walk(seconds=1.0).rig), "walk.bvh")
    sk = clip.skeleton
    frames = clip.frames.copy()
    shake = 0.004 * (-1.0) ** np.arange(len(frames))
    for axis in ("X", "Z"):
        frames[:, sk.dof_names.index(f"Hips.{axis}position")] += shake
    shaken = clip.with_frames(frames)
    size = stature(sk)
    feet = ["RightAnkle_end", "LeftAnkle_end"]
    still = resting_contacts(clip, feet, rest_floor(clip, size), size).mask
    mask = resting_contacts(shaken, feet, rest_floor(shaken, size), size).mask
    stance = int(np.argmax(still[0]))
    assert still[0, stance] and still[1, stance]  # the foot rests from the first frame
    assert mask[0, stance] and mask[1, stance]
    assert (mask[-1] == mask[-2]).all()


def test_a_source_shaking_at_30_fps_rests_where_it_would_without_the_shake():
    """The procedural walk at 30 fps with 0.2 degrees of noise on every channel and 1 mm on the
    root (not low-passed: the filter is under a frame wide there), six draws of the noise: the
    retarget's rest detection finds at least 95 % of the frames its feet rest in without the
    noise, and beyond them only frames at a rest's ends, at most two at each (a rest carried on
    through the shake, cleanup/shaking.py). On plain speeds the shake hid up to 17 % of them
    (one draw 83 %, three under 95 %), rests' ends it then left to follow the shake
    (cleanup.shaking's slow_through_noise, as `deik clip` reads rests)."""

    from deik.io.bvh import parse_bvh
    from deik.retargeting.keypoints import stature
    from deik.retargeting.resting import rest_floor, resting_contacts

    feet = ["RightAnkle", "RightAnkle_end", "LeftAnkle", "LeftAnkle_end"]
    for seed in range(6):
        case = noisy(procedural_walk(fps=30.0), seed=seed)
        clean, shaken = (parse_bvh(format_rig(rig), "walk.bvh") for rig in (case.truth, case.rig))
        size = stature(clean.skeleton)
        still = resting_contacts(clean, feet, rest_floor(clean, size), size).mask
        found = resting_contacts(shaken, feet, rest_floor(shaken, size), size).mask
        assert (found & still).sum() >= 0.95 * still.sum(), seed
        near = still.copy()
        for shift in (1, 2):
            near[shift:] |= still[:-shift]
            near[:-shift] |= still[shift:]
        assert not (found & ~near).any(), seed


@pytest.mark.shared_data
@pytest.mark.parametrize("name, seed", [("kick", 0), ("kick", 1), ("kick", 2), ("punch", 2), ("punch", 11)])
def test_the_shared_kick_shaking_at_30_fps_keeps_its_resting_feet_still_on_a_robot(tmp_path, name, seed):
    """judging/cases.py's noisy transform (0.2 degrees on every channel, 1 mm on the root, 12 mm
    under the floor, 30 fps) of the kick and the punch, with its own draw of the noise (seed 0)
    and others, onto human.urdf, judged against the clip without the noise: the noise hid the
    last frame of the kicking foot's first rest and it stepped 6 mm a frame there; with the other
    draws a rest's first or last frame read fast and the foot stepped 17-24 mm a frame (until a
    rest carried on through its edges: cleanup/shaking.py); now every resting point slides under
    a millimetre a frame."""
    from benchmarks.retarget_quality import HUMAN_URDF, URDF_MAP, WRISTS, onto_robot
    from helpers import shared_path
    from judging.cases import source_case

    case = noisy(source_case(shared_path("humanoid", f"humanoid3d_{name}.bvh")), seed=seed)
    source, truth = tmp_path / f"{name}_noisy.bvh", tmp_path / f"{name}.bvh"
    source.write_text(format_rig(case.rig))
    truth.write_text(format_rig(case.truth))
    measured = onto_robot(source, HUMAN_URDF, URDF_MAP, tmp_path, WRISTS, truth)
    assert measured["sliding_max_mm_per_frame"] <= 1.0, measured
    assert measured["penetration_max_mm"] <= 2.0 and measured["step_excess_max"] <= 1.0, measured
