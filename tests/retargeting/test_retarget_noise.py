"""`deik retarget` low-passes a source that shakes at a high frame rate, as `deik clip` does
(cleanup/noise.py), judged by the benchmarks' independent measurement (judging/retargets.py)
against the source without its noise."""

import json

from deik.cleanup.noise import LOW_PASS
from deik.cli import main
from judging.cases import noisy
from judging.retargets import judge, read_bvh_file, rig_pairing
from judging.rigs import format_rig
from judging.walk import procedural_walk


def test_a_source_shaking_at_120_fps_is_low_passed_and_its_feet_stay_planted(tmp_path, capsys):
    """The procedural walk at 120 fps with 0.2 degrees of noise on every channel, 1 mm on the
    root and 12 mm under the floor, onto longer legs: kept as captured, its resting feet slid
    21 mm a frame and a point's top speed was 1.57x its scaled source's; low-passed first, the
    summary says so and they slide under 5 mm with no point faster than 1.1x."""
    case = noisy(procedural_walk(fps=120.0))
    source, truth = tmp_path / "shaking.bvh", tmp_path / "truth.bvh"
    source.write_text(format_rig(case.rig))
    truth.write_text(format_rig(case.truth))
    out, report = tmp_path / "out.bvh", tmp_path / "out.json"
    argv = ["retarget", str(source), "--scale", "LeftHip=1.1,RightHip=1.1", "--out", str(out), "--json", str(report)]
    assert main(argv) == 0
    assert "capture noise 0.00256 m at rest: low-passed by Gaussians of up to 22 ms" in capsys.readouterr().out
    written = json.loads(report.read_text())
    assert written["noise"]["low_pass_s"] == LOW_PASS
    clean = read_bvh_file(truth)
    measured = judge(
        clean, rig_pairing(clean, read_bvh_file(out), written["floor"]["height"]), ["LeftElbow_end"], 1000.0
    )
    assert measured["sliding_max_mm_per_frame"] < 5.0, measured
    assert measured["speed_peak_ratio_max"] < 1.1, measured
