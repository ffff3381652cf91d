"""Smoke test of benchmarks/clip_frames.py on a short loop, and the looped walk it times."""

import json

import numpy as np
import pytest

from benchmarks.clip_frames import loop_clip, main
from deik.cleanup.contacts import detect_contacts
from deik.io.bvh import read_bvh
from deik.model.kinematics import forward_kinematics
from helpers import shared_path


@pytest.mark.shared_data
def test_the_looped_walk_is_one_long_walk_without_jumps():
    walk = read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))
    clip = loop_clip(walk, 200)
    assert clip.n_frames == 200 and clip.layout == walk.layout and clip.frame_time == walk.frame_time
    kin = forward_kinematics(clip.skeleton, clip.frames)
    root = kin.position("Hips")
    assert root[-1, 0] - root[0, 0] > 5 * 1.2  # five strides of about 1.24 m along +X
    steps = np.linalg.norm(np.diff(kin.p_world_frame, axis=0), axis=-1).max(axis=1)
    original = forward_kinematics(walk.skeleton, walk.frames).p_world_frame
    assert steps.max() < 1.05 * np.linalg.norm(np.diff(original, axis=0), axis=-1).max()
    assert np.abs(np.diff(clip.frames, axis=0)).max() < np.pi / 2  # Euler channels continuous
    assert (clip.frames >= clip.skeleton.lower).all() and (clip.frames <= clip.skeleton.upper).all()
    contacts = detect_contacts(clip)
    np.testing.assert_array_equal(contacts.mask[40:78], contacts.mask[78:116])  # every cycle alike


def test_benchmark_smoke_run_writes_json_markdown_and_png(shared_data, tmp_path, capsys):
    record = main(["--frames", "60", "--repeats", "1", "--out", str(tmp_path)])
    assert "frames/s" in capsys.readouterr().out
    result = json.loads((tmp_path / "clip_frames.json").read_text())
    assert result == json.loads(json.dumps(record)) and result["frames"] == 60 and result["best_seconds"] > 0
    assert result["frames_per_second"] == 60 / result["best_seconds"] == result["figures"]["frames per second"]
    assert result["settings"]["population"] > 0 and result["settings"]["device"] == "cpu"
    stages = [stage["stage"] for stage in result["stages"]]
    assert stages[0] == "warm start" and stages[-1] == "calm" and result["passes"] == len(stages) - 2
    # every resting point planted: the frames whose change would make a point jolt are taken
    # back and listed unmet (44 of 60 with seed 0)
    assert result["frames_met"] >= 40
    sliding = result["metrics"]["sliding_mean_mm_per_frame"]
    assert sliding["before"] > 1.0 and sliding["after"] < 1.0
    (target,) = result["targets"]
    assert result["environment"]["numba_threads"] >= 1 and target["goal"] == pytest.approx(0.6)  # 10 s per 1000
    assert target["met"] == (result["best_seconds"] <= 0.6)
    assert (tmp_path / "clip_frames.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip_frames.json", "clip_frames.md", "clip_frames.png"]
