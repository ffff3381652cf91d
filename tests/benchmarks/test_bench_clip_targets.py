"""The README's clip table is that of benchmarks/results/clip_targets.json, row for row (the
counts its text states are checked with the README's other figures, tests/readme_figures.py)."""

import json

import numpy as np
from scipy.spatial.transform import Rotation

from benchmarks.clip_targets import chosen_cases, readme_table
from helpers import ROOT
from judging.deepmimic import JOINTS, bvh_text

README = (ROOT / "README.md").read_text()
RESULTS = json.loads((ROOT / "benchmarks" / "results" / "clip_targets.json").read_text())


def test_the_readme_table_is_the_benchmark_s():
    assert readme_table(RESULTS["cases"]) in README
    assert RESULTS["command"].startswith("python -m benchmarks.clip_targets")  # every clip, the default command
    # 8 shared clips, each as it is, on the studio rig and transformed; 5 with a cut; 3 standing
    # still; 6 with fingers and toes; 3 resting lying down; 4 at 120 fps; 5 noisy at 60 fps or more;
    # 8 with fingers and toes and noise; 2 with fingers the capture moves; 3 with twist bones; 8 with
    # toes the capture bends, and 8 of those with noise; 8 at 50 fps
    assert len(RESULTS["cases"]) == 87


def test_a_clip_with_a_bind_pose_or_a_glitch_meets_the_targets_of_the_clip_itself():
    """The README: deik cleans a clip with a cut as if the jump were not there, so each such case
    meets the targets its clip meets (the judge reads where feet rest from the clip without the
    glitch frame, judging/cases.Case.truth)."""
    verdicts = {case["case"]: case["verdicts"] for case in RESULTS["cases"]}
    cut = [name for name in verdicts if name.endswith(("_bind", "_glitch"))]
    assert len(cut) == 5
    for name in cut:
        own = verdicts[name.rsplit("_", 1)[0]]
        differ = {target for target in own if verdicts[name][target] != own[target]}
        assert differ == set(), name


def test_a_clip_with_still_fingers_and_toes_finds_the_foot_runs_of_the_clip_itself():
    """The README: each `_digits` case measures as its clip does (its sliding, depth and travel:
    tests/readme_figures.py), with at most one foot run fewer found."""
    cases = {case["case"]: case for case in RESULTS["cases"]}
    fingered = [name for name in cases if name.endswith("_digits")]
    assert len(fingered) == 6
    for name in fingered:
        own = cases[name[: -len("_digits")]]
        assert own["steps_matched"] - cases[name]["steps_matched"] <= 1, name


def test_a_clip_whose_fingers_move_measures_as_with_still_fingers():
    """The README: the get-up and the crawl whose capture moves the fingers (`_fingers`) clean as
    with still ones (`_digits`): a hand's fingers are left as captured either way."""
    cases = {case["case"]: case for case in RESULTS["cases"]}
    moving = [name for name in cases if name.endswith("_fingers")]
    assert len(moving) == 2
    for name in moving:
        still = cases[name[: -len("_fingers")] + "_digits"]
        for key, within in (("sliding_mm_per_frame", 0.05), ("depth_mm", 0.5), ("travel_m", 0.01)):
            assert abs(cases[name][key] - still[key]) <= within, (name, key)
        assert cases[name]["verdicts"] == still["verdicts"], name


def test_a_clip_on_a_rig_with_twist_bones_measures_as_its_clip():
    """The README: the twist bones riding on the limbs (`_twists`) change nothing the judge
    measures: each case measures as its clip does and meets the same targets."""
    cases = {case["case"]: case for case in RESULTS["cases"]}
    twisted = [name for name in cases if name.endswith("_twists")]
    assert len(twisted) == 3
    for name in twisted:
        own = cases[name[: -len("_twists")]]
        for key, within in (("sliding_mm_per_frame", 0.05), ("depth_mm", 0.5), ("travel_m", 0.01)):
            assert abs(cases[name][key] - own[key]) <= within, (name, key)
        assert cases[name]["verdicts"] == own["verdicts"], name


def test_transforms_name_each_clip_as_it_is_and_so_transformed(shared_data):
    """`--transforms limbs fast`: each clip of the folder, then the same clip so transformed, in
    the folder's order (benchmarks/results/clip_probe: the DeepMimic family's other clips)."""
    chosen = chosen_cases(shared_data / "humanoid", ["walk", "kick"], ["limbs", "fast"])
    assert [case.name for case in chosen] == ["kick", "kick_limbs", "kick_fast", "walk", "walk_limbs", "walk_fast"]
    assert chosen[1].bone_scale["LeftKnee"] != 1.0 and len(chosen[2].rig.frames) < len(chosen[0].rig.frames)


def test_a_deepmimic_motion_becomes_the_shared_clip_it_was_made_from(shared_data):
    """The shared crawl written back as a DeepMimic motion (its Euler channels as quaternions
    w, x, y, z by SciPy, its knees' and elbows' Z angle in radians) converts to the clip again."""
    text = (shared_data / "humanoid" / "humanoid3d_crawl.bvh").read_text()
    hierarchy, motion = text.split("MOTION")
    lines = motion.strip().splitlines()
    frame_time, values = float(lines[1].split()[-1]), np.array([line.split() for line in lines[2:]], float)
    order = [line.split()[1] for line in hierarchy.splitlines() if line.strip().startswith("JOINT")]
    start = {name: 6 + 3 * k for k, name in enumerate(order)}

    def quaternion(degrees):
        x, y, z, w = Rotation.from_euler("ZXY", degrees, degrees=True).as_quat().T
        return np.c_[w, x, y, z]

    parts = [np.full((len(values), 1), frame_time), values[:, :3], quaternion(values[:, 3:6])]
    for name, count in JOINTS:
        angles = values[:, start[name] : start[name] + 3]
        parts.append(quaternion(angles) if count == 4 else np.radians(angles[:, :1]))
    again = bvh_text({"Frames": np.hstack(parts).tolist()}, hierarchy, order)
    back = np.array([line.split() for line in again.split("MOTION")[1].strip().splitlines()[2:]], float)
    np.testing.assert_allclose(back, values, atol=2e-6)
