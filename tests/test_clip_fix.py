"""fix_clip and `deik clip` on the real clips: planted feet stop sliding while the pose stays
close to the performance; bad input is refused before anything is written."""

import numpy as np
import pytest

from conftest import shared_path
from deik.cli import main
from deik.clips.contacts import detect_contacts, foot_sites
from deik.clips.metrics import foot_sliding, joint_deviation
from deik.clips.problem import ClipGoals, neighbour_displacement
from deik.clips.solver import fix_clip
from deik.io.bvh import read_bvh


@pytest.mark.parametrize("name", ["walk", "run"])
def test_planted_feet_stop_sliding_and_the_pose_stays_close(name):
    clip = read_bvh(shared_path("humanoid", f"humanoid3d_{name}.bvh"))
    contacts = detect_contacts(clip, foot_sites(clip.skeleton))
    fix = fix_clip(clip, ClipGoals(contacts), seed=0)
    before, after = foot_sliding(clip, contacts), foot_sliding(fix.clip, contacts)
    assert np.nanmean(before) > 1.5e-3  # the captured feet really slide (metres per frame)
    assert np.nanmean(after) < 1e-3
    mean_deviation, _ = joint_deviation(clip, fix.clip)
    assert mean_deviation.mean() < 5.0
    # the fixed clip keeps the input's layout and frame time
    assert fix.clip.layout == clip.layout and fix.clip.frame_time == clip.frame_time


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


@pytest.mark.parametrize("extra,fragment", [
    (["--reach", "NoSuchHand=0,1,0@3:5"], "joint or site 'NoSuchHand' not found"),
    (["--reach", "LeftElbow_end=0,1,0@30:60"], "valid frames: 0..38"),
    (["--plant-feet", "LeftAnkle_end:30-45"], "LeftAnkle_end"),
    (["--reach", "LeftElbow_end={tmp}/track.csv"], "missing"),
    (["--plant-feet", "auto", "--plant-feet", "LeftAnkle:1-3"], "cannot be combined"),
    (["--fidelity", "3"], "fidelity weight must lie in [0, 1]"),
])
def test_clip_cli_mistakes_exit_2_and_write_nothing(tmp_path, capsys, extra, fragment):
    (tmp_path / "track.csv").write_text("frame,x,y\n1,0,1\n")
    out = tmp_path / "out"
    out.mkdir()
    argv = ["clip", str(shared_path("humanoid", "humanoid3d_walk.bvh")), "--out", str(out / "fixed.bvh"),
            "--report", str(out / "report.png")] + [e.format(tmp=tmp_path) for e in extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err, err
    assert list(out.iterdir()) == []


def test_clip_cli_writes_clip_report_and_json(tmp_path, capsys):
    out = tmp_path / "fixed.bvh"
    argv = ["clip", str(shared_path("humanoid", "humanoid3d_run.bvh")), "--out", str(out),
            "--report", str(tmp_path / "report.png"), "--json", str(tmp_path / "report.json"), "--passes", "1"]
    assert main(argv) == 0, capsys.readouterr().err
    captured = capsys.readouterr()
    assert "contacts (detected)" in captured.err and "foot sliding mean (mm/frame)" in captured.out
    assert read_bvh(out).n_frames == 25
    assert (tmp_path / "report.png").stat().st_size > 0 and (tmp_path / "report.json").stat().st_size > 0
