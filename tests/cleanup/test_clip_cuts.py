"""Clips whose pose jumps (cleanup/cuts.py): a bind pose before or after the motion, a glitch, two
takes in one file. Made from the procedural walk (judging/walk.py), whose feet rest
still on the floor through every stance: whatever jumps beside it, the cleaned walk keeps them
still, and nothing that only moves fast is taken for a jump."""

import dataclasses

import numpy as np
import pytest

import deik
from deik.cleanup.body import body_of
from deik.cleanup.cuts import CUT_RATIO, abruptness, find_cuts, window
from deik.io.bvh import parse_bvh
from judging.cases import TRANSFORMS, Case, anon, bind, fast, glitch, source_case, studio
from judging.rigs import Rig, format_rig, pose_points, world_frames
from judging.walk import procedural_walk


def read(rig: Rig, name: str = "walk"):
    return parse_bvh(format_rig(rig), f"{name}.bvh")


def rotation_columns(rig: Rig) -> list[int]:
    return [k for k, (_, c) in enumerate(rig.columns) if c.endswith("rotation")]


def with_bind_pose(rig: Rig, where: str) -> Rig:
    """`rig` with a frame of every rotation at 0 (the rig's T-pose, where the first or last
    frame stands) before or after its motion."""
    frames = rig.frames
    end = frames[:1] if where == "before" else frames[-1:]
    bind = end.copy()
    bind[:, rotation_columns(rig)] = 0.0
    frames = np.concatenate([bind, frames]) if where == "before" else np.concatenate([frames, bind])
    return dataclasses.replace(rig, frames=frames)


def sole_slide_mm(rig: Rig, frames: slice) -> float:
    """The largest step along the ground of an ankle's End Site (the toe, on the sole) between two
    frames in which it lies within 1 mm of its lowest height in the capture: the procedural
    walk's resting toes, measured on `rig`'s own kinematics (judging/rigs.py)."""
    R, p = world_frames(dataclasses.replace(rig, frames=rig.frames[frames]))
    worst = 0.0
    for _, j, offset in rig.sites:
        if "Ankle" not in rig.names[j]:
            continue
        toe = p[:, j] + np.einsum("nij,j->ni", R[:, j], offset)
        down = toe[:, 1] <= toe[:, 1].min() + 1e-3
        step = np.linalg.norm(np.diff(toe[:, [0, 2]], axis=0), axis=-1)
        worst = max(worst, float(step[down[1:] & down[:-1]].max(initial=0.0)))
    return 1000.0 * worst


def cleaned_rig(rig: Rig, tmp_path, name: str) -> tuple[Rig, dict]:
    """(the cleaned clip as the clip tools read it back, deik's report) of `rig`."""
    from judging.rigs import parse_rig

    cleaned = deik.clean_clip(read(rig, name))
    out = tmp_path / f"{name}_out.bvh"
    deik.write_bvh(out, cleaned.clip)
    return parse_rig(out.read_text()), cleaned.report


@pytest.mark.parametrize("where", ["before", "after"])
def test_a_bind_pose_beside_the_walk_is_written_back_and_the_walk_keeps_its_feet_still(where, tmp_path):
    walk = procedural_walk().rig
    rig = with_bind_pose(walk, where)
    bind = 0 if where == "before" else len(rig.frames) - 1
    motion = slice(1, None) if where == "before" else slice(0, -1)
    assert sole_slide_mm(rig, motion) < 1e-3  # the capture's resting toes stand still
    out, report = cleaned_rig(rig, tmp_path, f"bind_{where}")
    assert report["cuts"]["kept_frames"] == [bind]
    assert report["cuts"]["cut_after_frames"] == [0 if where == "before" else len(rig.frames) - 2]
    assert sole_slide_mm(out, motion) < 0.5  # the cleaned walk's too
    np.testing.assert_allclose(out.frames[bind], rig.frames[bind], atol=1e-6)  # the bind pose as captured
    # its straight legs reach under the floor where the walk's bent ones stood: listed, not met
    assert pose_points(rig)[bind, :, 1].min() < -0.01
    assert not report["met_per_frame"][bind] and sum(report["met_per_frame"]) == len(rig.frames) - 1


def test_a_glitch_in_the_walk_is_blended_across(tmp_path):
    walk = procedural_walk().rig
    frames = walk.frames.copy()
    k = len(frames) // 2
    frames[k, rotation_columns(walk)] = 0.0
    rig = dataclasses.replace(walk, frames=frames)
    out, report = cleaned_rig(rig, tmp_path, "glitch")
    assert report["cuts"]["bridged_frames"] == [k] and report["cuts"]["kept_frames"] == []
    # the cleaned frame lies between its neighbours, as the walk does, not at the glitch
    _, p_out = world_frames(out)
    _, p_walk = world_frames(walk)
    assert np.abs(p_out[k] - p_walk[k]).max() < 0.02
    assert np.abs(p_out[k] - (p_out[k - 1] + p_out[k + 1]) / 2).max() < 0.01


def test_two_takes_in_one_file_are_found_and_reported(tmp_path):
    walk = procedural_walk().rig
    second = walk.frames.copy()
    second[:, 0] += 3.0  # the second take starts 3 m further along: the root's Xposition
    rig = dataclasses.replace(walk, frames=np.concatenate([walk.frames, second]))
    n = len(walk.frames)
    cuts = find_cuts(read(rig), body_of(read(rig)).span)
    assert cuts.steps.tolist() == [n - 1] and cuts.between_takes.tolist() == [n - 1]
    assert not cuts.kept.any() and not cuts.bridged.any()


def starting_still(case: Case) -> Case:
    """`case` standing still for half a second in its first pose, then walking off at once."""
    rig = case.rig
    hold = int(round(0.5 / rig.frame_time))
    frames = np.concatenate([np.repeat(rig.frames[:1], hold, axis=0), rig.frames])
    return dataclasses.replace(case, rig=dataclasses.replace(rig, frames=frames))


@pytest.mark.parametrize(
    "make",
    [
        lambda walk: walk,
        studio,  # centimetres, 30 fps
        anon,  # 120 fps
        lambda walk: fast(fast(walk)),  # four times the speed
        lambda walk: fast(fast(studio(walk))),  # four times the speed at 30 fps: 7.5 poses a second
        starting_still,
    ],
    ids=["walk", "studio", "120fps", "4x", "4x_at_30fps", "from_still"],
)
def test_motion_that_only_moves_fast_has_no_cuts(make):
    case = make(procedural_walk())
    clip = read(case.rig)
    assert find_cuts(clip, body_of(clip).span).steps.tolist() == []


def test_a_retarget_holds_the_motion_where_the_source_has_its_bind_pose():
    walk = procedural_walk().rig
    plain = deik.retarget(read(walk), scale={"RightHip": 1.1, "LeftHip": 1.1})
    bound = deik.retarget(read(with_bind_pose(walk, "before")), scale={"RightHip": 1.1, "LeftHip": 1.1})
    assert bound.report["cuts"]["kept_frames"] == [0]
    frames = np.asarray(bound.motion.frames)
    np.testing.assert_allclose(frames[0], frames[1], atol=1e-5)  # held
    # the motion after it retargets as the walk alone does, within a millimetre at every joint
    p_plain = plain.motion.kinematics.p_world_frame
    p_bound = bound.motion.kinematics.p_world_frame[1:]
    assert np.abs(p_bound - p_plain).max() < 1e-3


SHARED = ["crawl", "dance_a", "getup_facedown", "jump", "kick", "punch", "run", "walk"]


def tenth_of_a_second(case: Case) -> Case:
    """`case` at 10 poses a second: every n-th frame of it."""
    step = int(round(0.1 / case.rig.frame_time))
    rig = case.rig
    return dataclasses.replace(
        case, rig=dataclasses.replace(rig, frames=rig.frames[::step].copy(), frame_time=rig.frame_time * step)
    )


def largest_abruptness(rig: Rig, skip: list[int] = ()) -> float:
    clip = read(rig)
    ratios = abruptness(clip.kinematics.p_world_frame, body_of(clip).span, window(clip.frame_time))
    return float(np.delete(ratios, list(skip)).max(initial=0.0))


@pytest.mark.parametrize("name", SHARED)
def test_every_shared_clip_moves_without_cuts_and_a_t_pose_beside_or_in_it_is_one(name, shared_data):
    """docs/clips.md ("Cuts"): motion reaches at most 4.8 times its typical acceleration (under
    CUT_RATIO; 4.3 without the fingers of the digits transform, their tips the fastest points)
    as captured, on another rig family, at 120 fps, played backwards or four times as
    fast, at 10 poses a second, with limbs rescaled or noise; a T-pose before it, after it or in
    its middle at least 9 times. The one cut on the shared clips is the walk's loop seam (step
    18: its loop starts again), 7.3 times."""
    base = source_case(shared_data / "humanoid" / f"humanoid3d_{name}.bvh")
    # a stand joins a held pose to the clip's first frame, where a clip cut from a longer take
    # may already move at full speed: a jump in velocity, not motion
    variants = [base] + [make(base) for key, make in TRANSFORMS.items() if key not in ("bind", "glitch", "stand")]
    variants += [fast(fast(base)), fast(studio(base)), tenth_of_a_second(base)]
    for case in variants:
        clip = read(case.rig)
        cuts = find_cuts(clip, body_of(clip).span)
        seams = cuts.between_takes.tolist() if name == "walk" else []  # the walk's seam moves with its frames
        assert cuts.steps.tolist() == seams and len(seams) <= 1, case.name
        assert not cuts.kept.any() and not cuts.bridged.any()
        assert largest_abruptness(case.rig, seams) < 5.0, case.name
    if name == "walk":  # its seam: the loop starts again at frame 19
        clip = read(base.rig)
        ratios = abruptness(clip.kinematics.p_world_frame, body_of(clip).span, window(clip.frame_time))
        assert np.flatnonzero(ratios >= CUT_RATIO).tolist() == [18] and 7.0 < ratios[18] < 7.6
    for rig in (bind(base).rig, with_bind_pose(base.rig, "after"), glitch(base).rig):
        assert largest_abruptness(rig) >= 9.0


def written_differently(rig: Rig) -> Rig:
    """`rig` with the same rotations written otherwise: a third of its frames as each joint's
    Euler twin (a + 180, 180 - b, c + 180), every fourth frame a whole turn further."""
    frames = rig.frames.copy()
    n = len(frames)
    twins = slice(n // 3, 2 * n // 3)
    for j, channels in enumerate(rig.channels):
        first = sum(len(c) for c in rig.channels[:j])
        a, b, c = [first + k for k, name in enumerate(channels) if name.endswith("rotation")]
        frames[twins, a] += 180.0
        frames[twins, b] = 180.0 - frames[twins, b]
        frames[twins, c] += 180.0
    frames[::4, rotation_columns(rig)] += 360.0
    return dataclasses.replace(rig, frames=frames)


def test_rotations_written_as_euler_twins_or_whole_turns_clean_as_the_clip_itself(shared_data, tmp_path):
    """The same rotations in other channel values are the same motion: no leap, no cut, the same
    cleaned clip, for a third of the shared dance written as Euler twins."""
    dance = source_case(shared_data / "humanoid" / "humanoid3d_dance_a.bvh").rig
    other = written_differently(dance)
    assert np.abs(world_frames(other)[1] - world_frames(dance)[1]).max() < 1e-9
    assert np.abs(other.frames - dance.frames).max() > 300
    out_dance, report_dance = cleaned_rig(dance, tmp_path, "dance")
    out_other, report_other = cleaned_rig(other, tmp_path, "other")
    assert report_other["cuts"]["cut_after_frames"] == report_dance["cuts"]["cut_after_frames"] == []
    assert report_other["met_per_frame"] == report_dance["met_per_frame"]
    assert np.abs(world_frames(out_other)[1] - world_frames(out_dance)[1]).max() < 1e-4  # 0.1 mm: the files round


def test_info_clip_and_retarget_say_where_the_pose_jumps_and_what_became_of_it(tmp_path, capsys):
    from deik.cli.app import main

    walk = procedural_walk().rig
    frames = with_bind_pose(walk, "before").frames.copy()
    middle = len(frames) // 2
    frames[middle, rotation_columns(walk)] = 0.0
    path = tmp_path / "bound.bvh"
    path.write_text(format_rig(dataclasses.replace(walk, frames=frames)))
    bind = "frame 0: a pose the motion jumps from or to (a bind pose); "
    glitch = f"frame {middle}: the pose jumps away and back (a glitch); "
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "  " + bind + "deik clip writes it back as captured" in out and "  " + glitch in out
    assert main(["clip", str(path), "--out", str(tmp_path / "out.bvh"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert bind + "written back as captured" in out and glitch + "blended across" in out
    scaled = ["retarget", str(path), "--scale", "RightHip=1.1", "--out", str(tmp_path / "r.bvh"), "--quiet"]
    assert main(scaled) == 0
    assert bind + "the target holds the motion's nearest frame there" in capsys.readouterr().out


def test_a_summary_names_a_few_seams_and_counts_the_rest():
    from deik.viz.text import SEAMS_SHOWN, cut_lines

    record = {"kept_frames": [], "bridged_frames": [], "between_takes": list(range(10, 200, 10))}
    (line,) = cut_lines(record, ("kept", "blended", "across"))
    assert line.startswith("the pose jumps between frames 10 and 11, 20 and 21,")
    assert f"and {len(record['between_takes']) - SEAMS_SHOWN} more" in line and line.endswith("; across")


def test_a_pose_held_then_left_with_a_leap_is_a_seam_and_its_held_frames_stay():
    """A capture that froze for four frames and caught up in one: nothing stood in for (a seam
    where the leap is a cut), for a point resting while it froze rests in the capture too."""
    walk = procedural_walk().rig
    frames = walk.frames.copy()
    k = len(frames) // 2
    frames[k : k + 4] = frames[k - 1]
    clip = read(dataclasses.replace(walk, frames=frames))
    cuts = find_cuts(clip, body_of(clip).span)
    assert cuts.between_takes.tolist() in ([], [k + 3]) and not cuts.bridged.any() and not cuts.kept.any()
    assert cuts.stand_in(clip) is clip


def test_a_point_resting_on_both_sides_of_a_seam_reads_slow_beside_it():
    """Smoothed across a jump, a still point read fast in the frames beside it (the looped get-up's
    heel: 0.35-7.4 m/s at a raw 0.02): each run between seams is smoothed and differentiated on
    its own, and a contact over a seam is two, planted apart."""
    from deik.cleanup.contacts import Contacts
    from deik.cleanup.speeds import point_speeds

    p = np.zeros((20, 1, 3))
    p[10:] = [0.75, 0.0, 0.0]  # still, then a leap between takes, then still
    joined = point_speeds(p, 1 / 30)
    assert (joined[8:12, 0] > 1.0).all()
    np.testing.assert_array_equal(point_speeds(p, 1 / 30, np.array([9])), 0.0)
    contacts = Contacts(("heel",), np.ones((20, 1), bool), True, 0.02, 0.2, 0.0, seams=(9,))
    assert contacts.intervals(0) == [(0, 10), (10, 20)]
    assert Contacts(("heel",), np.ones((20, 1), bool), True, 0.02, 0.2, 0.0).intervals(0) == [(0, 20)]


@pytest.mark.shared_data
def test_a_resting_point_sliding_beside_a_seam_between_takes_is_listed(shared_data, tmp_path):
    """The shared dance as two takes in one file, the second a metre along: a toe resting up to the
    seam slid 4.3 mm a frame in frames the report called met (its speed read across the jump).
    Judged by the benchmarks' own detector (judging/clips.py): every frame that slides or sinks
    past the targets is listed."""
    from judging.clips import judge
    from judging.rigs import parse_rig

    case = source_case(shared_data / "humanoid" / "humanoid3d_dance_a.bvh")
    second = case.rig.frames.copy()
    second[:, 0] += 1.0  # the root's Xposition
    rig = dataclasses.replace(case.rig, frames=np.concatenate([case.rig.frames, second]))
    two = dataclasses.replace(case, rig=rig)
    source = tmp_path / "two.bvh"
    source.write_text(format_rig(rig))
    cleaned = deik.clean_clip(deik.read_bvh(source))
    out = tmp_path / "out.bvh"
    deik.write_bvh(out, cleaned.clip)
    unmet = ~np.array(cleaned.report["met_per_frame"], bool)
    figures = judge(two, rig, parse_rig(out.read_text(), rig.position_mode), unmet)
    assert figures["misses_listed"], figures
    assert cleaned.report["cuts"]["between_takes"] == [len(case.rig.frames) - 1]
