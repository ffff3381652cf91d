"""`deik view` without a browser: every bad input gets one line naming the problem and the fix
before anything is served, a missing viser names the extra to install, and the server answers
with the viewer page until it is stopped."""

import json
import sys
import threading
import urllib.request

import numpy as np
import pytest

import deik
from deik.cli.app import build_parser, main
from deik.cli.view import build_scene

pytest.importorskip("viser", reason='deik view needs viser: pip install "deik[view]"')


def _clip(path, frames):
    human = deik.humanoid()
    deik.write_bvh(path, deik.Clip.from_poses(human, np.tile(human.reference, (frames, 1)), frame_time=1 / 30))
    return str(path)


def _pose(path, data=None):
    if data is None:
        problem = deik.Problem(deik.chain(3, dims=3), [deik.Position("tip", (1.0, 1.0, 1.0))])
        data = deik.solve(problem, population=16, generations=10, seed=0).to_dict()
    path.write_text(json.dumps(data))
    return str(path)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["missing.bvh"], "missing.bvh: no such BVH file"),
        (["{pose}", "--pose", "{pose}"], "is a pose JSON and draws itself"),
        (["humanoid", "--report", "{pose}"], "--report marks a clip: give the clip it reports on as FILE"),
        (["{clip}", "--report", "{pose}"], 'is no clip report: it has no "frames" count'),
        (["{clip}", "--compare", "{short}"], "--compare {short}: has 3 frames, the viewed file 5"),
        (["{clip}", "--compare", "other.urdf"], "--compare 'other.urdf': give a .bvh clip or a pose .json"),
        (["chain:3", "--pose", "{pose}"], "--pose {pose}: its angles hold 6 values, the skeleton has 3 DOFs"),
        (["{old}"], "has no world frames to draw"),
        (["humanoid", "--port", "70000"], "--port 70000: give a port from 1 to 65535"),
        (["humanoid", "--base", "x"], "--base only apply to a URDF robot"),
    ],
)
def test_bad_inputs_get_one_line_before_anything_is_served(tmp_path, capsys, argv, message):
    names = {
        "clip": _clip(tmp_path / "clip.bvh", 5),
        "short": _clip(tmp_path / "short.bvh", 3),
        "pose": _pose(tmp_path / "pose.json"),
        "old": _pose(tmp_path / "old.json", {"angles": [0.1, 0.2]}),
    }
    argv = [a.format(**names) for a in argv]
    message = message.format(**names)
    assert main(["view", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and message in err, err


def test_a_missing_viser_names_the_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "viser", None)
    assert main(["view", "humanoid"]) == 2
    assert 'the 3-D view needs viser: pip install "deik[view]"' in capsys.readouterr().err


def test_the_server_answers_with_the_viewer_page_until_stopped(tmp_path):
    from deik.viz.viewer import serve

    args = build_parser().parse_args(["view", _clip(tmp_path / "clip.bvh", 5), "--units", "cm"])
    scene = build_scene(args)
    assert (
        scene.n_steps == 5 and scene.step == "frame" and scene.unit == "cm" and scene.step_time == pytest.approx(1 / 30)
    )
    ready, stop = [], threading.Event()
    server = threading.Thread(
        target=serve, args=(scene, "127.0.0.1", 0), kwargs={"on_ready": ready.append, "stop": stop}
    )
    server.start()
    try:
        for _ in range(200):
            if ready:
                break
            stop.wait(0.05)
        (url,) = ready
        with urllib.request.urlopen(url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
    finally:
        stop.set()
        server.join(timeout=30)
    assert not server.is_alive()
