"""`deik view` without a browser: every bad input gets one line naming the problem and the fix
before anything is served, a missing viser names the extra to install, and the server answers
with the viewer page until it is stopped."""

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request

import numpy as np
import pytest

import deik
from deik.cli.app import build_parser, main
from deik.cli.view_command import build_scene
from helpers import ROOT

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


@contextlib.contextmanager
def serving(scene, port=0):
    """serve(scene) on a thread: yields its address once it answers, stops it on leaving."""
    from deik.viz.viewer import serve

    ready, stop = [], threading.Event()
    options = {"on_ready": ready.append, "stop": stop}
    server = threading.Thread(target=serve, args=(scene, "127.0.0.1", port), kwargs=options)
    server.start()
    try:
        for _ in range(400):
            if ready or not server.is_alive():
                break
            stop.wait(0.05)
        (url,) = ready
        yield url
    finally:
        stop.set()
        server.join(timeout=30)
    assert not server.is_alive()


def test_the_server_answers_with_the_viewer_page_until_stopped(tmp_path):
    scene = build_scene(build_parser().parse_args(["view", _clip(tmp_path / "clip.bvh", 5), "--units", "cm"]))
    assert (scene.n_steps, scene.step, scene.unit) == (5, "frame", "cm") and scene.step_time == pytest.approx(1 / 30)
    with serving(scene) as url, urllib.request.urlopen(url, timeout=10) as page:
        assert page.status == 200 and b"<html" in page.read().lower()


def test_a_taken_port_moves_to_the_next_free_one():
    scene = build_scene(build_parser().parse_args(["view", "chain:3"]))
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with serving(scene, port) as url:
            assert int(url.rsplit(":", 1)[1]) > port


@pytest.mark.parametrize("no_browser", [False, True])
def test_it_opens_the_browser_unless_told_not_to(tmp_path, no_browser):
    record = tmp_path / "opened.txt"
    script = tmp_path / "browser.py"
    script.write_text(f"import sys, pathlib\npathlib.Path({str(record)!r}).write_text(sys.argv[1])\n")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(BROWSER=f"{sys.executable} {script} %s", PYTHONPATH=str(ROOT / "src"))
    argv = [sys.executable, "-m", "deik", "view", "chain:3", "--port", "0"] + (["--no-browser"] if no_browser else [])
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = process.stdout.readline()
        url = line.split(" at ")[1].split()[0]
        for _ in range(100):
            if record.exists() or no_browser:
                break
            threading.Event().wait(0.05)
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "deik view: stopped" in err
    assert (not record.exists()) if no_browser else record.read_text() == url


def test_a_batch_pose_file_is_one_step_per_problem(tmp_path):
    human = deik.humanoid()
    targets = np.array([[0.4, 1.2, 0.3], [0.3, 1.4, 0.1], [-0.2, 1.0, 0.4]])
    problem = deik.Problem(human, [deik.Position("left_hand", targets)])
    result = deik.solve(problem, population=16, generations=10, seed=0)
    from deik.viz.marks import goal_targets

    path = _pose(tmp_path / "batch.json", {**result.to_dict(), "targets": goal_targets(problem)})
    scene = build_scene(build_parser().parse_args(["view", path]))
    assert (scene.n_steps, scene.step) == (3, "problem") and scene.unit == "length units"
    (marks,) = scene.marks
    assert np.allclose(marks.points[:, 0], targets)
    assert np.allclose(scene.figure.positions, deik.forward_kinematics(human, result.angles).p_world_frame)
    posed = build_scene(build_parser().parse_args(["view", "humanoid", "--pose", path]))
    assert (posed.n_steps, posed.step, posed.unit) == (3, "problem", "m")
    assert np.allclose(posed.figure.positions, scene.figure.positions) and np.allclose(
        posed.marks[0].points, marks.points
    )


@pytest.mark.parametrize(
    "host, message",
    [
        ("999.1.1.1", "--host '999.1.1.1' is not an IPv4 address"),
        ("no.such.host.invalid", "no such host name"),
        ("192.0.2.1", "is not an address of this machine"),  # TEST-NET-1: never this machine's
    ],
)
def test_a_host_that_cannot_be_served_on_is_refused_at_once(capsys, host, message):
    started = time.monotonic()
    assert main(["view", "chain:3", "--host", host, "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and message in err and err.count("\n") == 1
    assert time.monotonic() - started < 30  # not the minutes of trying port after port
