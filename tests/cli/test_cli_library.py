"""`deik clip DIR` and `deik retarget DIR` on folders of the shared clips: every *.bvh done (the
outputs are the one-clip command's, read back and checked), what is skipped said, a rerun
skipping the clips done and redoing a changed setting or input, a broken clip failing alone,
and a run killed mid-way resumed by running it again. The folder flags' mistakes get one line."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.io.atomic import JOURNAL, PARTIAL
from helpers import ROOT, shared_path

CLIPS = ("humanoid3d_run.bvh", "humanoid3d_walk.bvh")


def _folder(tmp_path, names=CLIPS, copies=1):
    """tmp/clips with the shared clips `names` (each `copies` times) and a file that is no clip."""
    folder = tmp_path / "clips"
    folder.mkdir()
    for name in names:
        for k in range(copies):
            stem = name[:-4] if copies == 1 else f"{name[:-4]}_{k}"
            shutil.copy(shared_path("humanoid", name), folder / f"{stem}.bvh")
    (folder / "notes.txt").write_text("not a clip")
    return folder


def _mtimes(folder):
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


@pytest.mark.shared_data
def test_a_folder_of_clips_is_fixed_and_a_rerun_skips_what_is_done(tmp_path, capsys):
    clips, out = _folder(tmp_path), tmp_path / "fixed"
    argv = ["clip", str(clips), "--out", str(out), "--json", str(out), "--workers", "2"]
    assert main(argv) == 0
    printed = capsys.readouterr()
    assert "skipped (not *.bvh, or a sub-folder): notes.txt" in printed.err
    assert "2 clips: 2 done, 0 skipped" in printed.out and "humanoid3d_walk.bvh  39      done" in printed.out
    for name in CLIPS:
        stem = name[:-4]
        fixed, original = deik.read_bvh(out / f"{stem}.bvh"), deik.read_bvh(clips / name)
        assert fixed.n_frames == original.n_frames and fixed.layout == original.layout
        report = json.loads((out / f"{stem}.json").read_text())
        # every frame met or listed: those whose fix would make a point jolt are taken back
        assert report["frames_met"] == sum(report["met_per_frame"]) > original.n_frames // 2
        sidecar = json.loads((out / f".{name}.deik.json").read_text())
        assert sidecar["record"]["frames"] == original.n_frames
        assert sidecar["record"]["metrics"]["sliding_max_mm_per_frame"] == pytest.approx(
            report["metrics"]["sliding_max_mm_per_frame"]["after"]
        )
    before = _mtimes(out)
    assert main(argv + ["--quiet"]) == 0
    assert "2 clips: 0 done, 2 skipped" in capsys.readouterr().out
    assert _mtimes(out) == before  # nothing rewritten
    with open(clips / CLIPS[0], "a") as file:  # another input: that clip only is redone
        file.write("\n")
    assert main(argv + ["--quiet"]) == 0
    assert "2 clips: 1 done, 1 skipped" in capsys.readouterr().out
    assert main(argv + ["--quiet", "--fidelity", "0.8"]) == 0  # another setting: every clip
    assert "2 clips: 2 done, 0 skipped" in capsys.readouterr().out


@pytest.mark.shared_data
def test_a_broken_clip_fails_alone_with_its_reason(tmp_path, capsys):
    clips, out = _folder(tmp_path, names=CLIPS[:1]), tmp_path / "fixed"
    (clips / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    assert main(["clip", str(clips), "--out", str(out), "--quiet"]) == 1
    printed = capsys.readouterr()
    (line,) = [line for line in printed.err.splitlines() if "broken.bvh" in line]
    assert line.startswith("deik: broken.bvh: failed: ") and "Traceback" not in printed.err
    assert "2 clips: 1 done, 0 skipped (done before with the same settings and input), 1 failed" in printed.out
    assert sorted(os.listdir(out)) == [".humanoid3d_run.bvh.deik.json", "humanoid3d_run.bvh"]


@pytest.mark.shared_data
def test_a_folder_retargeted_onto_the_urdf_human_gives_trajectories_and_views(tmp_path, capsys):
    clips, out, views = _folder(tmp_path), tmp_path / "robot", tmp_path / "views"
    argv = ["retarget", str(clips), "--map", str(ROOT / "examples/maps/shared_bvh_to_human_urdf.toml")]
    argv += ["--to", str(shared_path("robots", "human.urdf")), "--frames", "0:8", "--out", str(out)]
    assert main(argv + ["--view", str(views), "--quiet"]) == 0
    assert "2 clips: 2 done" in capsys.readouterr().out
    robot = deik.read_urdf(shared_path("robots", "human.urdf"))
    for name in CLIPS:
        header, *rows = (out / f"{name[:-4]}.csv").read_text().splitlines()
        columns = header.split(",")
        assert columns[:2] == ["frame", "time_s"] and len(rows) == 8
        joints = [n for n in columns[2:] if n in robot.dof_names]  # the robot's own, not the added root
        assert len(joints) == robot.n_dofs
        table = np.array([[float(v) for v in row.split(",")] for row in rows])
        values = table[:, [columns.index(n) for n in joints]]
        lower = np.array([robot.lower[robot.dof_names.index(n)] for n in joints])
        upper = np.array([robot.upper[robot.dof_names.index(n)] for n in joints])
        assert (values >= lower - 1e-9).all() and (values <= upper + 1e-9).all()  # within the robot's limits
        assert deik.read_bvh(views / f"{name[:-4]}.bvh").n_frames == 8
    assert main(argv + ["--quiet", "--view", str(views)]) == 0
    assert "2 clips: 0 done, 2 skipped" in capsys.readouterr().out
    assert main(argv + ["--quiet"]) == 0  # without --view: other outputs, so redone
    assert "2 clips: 2 done" in capsys.readouterr().out


def _sidecars(folder):
    """The finished clips' sidecars in `folder`, sorted: not a temporary file still being written
    (deik.io.atomic: `.deik-partial-...NAME.deik.json` matches the sidecars' pattern too)."""
    return sorted(p.name for p in folder.glob(".*.deik.json") if not p.name.startswith((PARTIAL, JOURNAL)))


@pytest.mark.shared_data
@pytest.mark.skipif(sys.platform == "win32", reason="kills a process group")
def test_a_run_killed_mid_way_resumes_where_it_stopped(tmp_path):
    clips, out = _folder(tmp_path, names=CLIPS[1:], copies=4), tmp_path / "fixed"
    command = [sys.executable, "-m", "deik", "clip", str(clips), "--out", str(out), "--balance", "--workers", "1"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.Popen(command + ["--quiet"], env=env, start_new_session=True, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not _sidecars(out) and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(run.pid, signal.SIGKILL)  # the run and its worker, mid-way through the library
    run.wait()
    finished = _sidecars(out)
    assert 1 <= len(finished) < 4, finished
    for path in out.glob("*.bvh"):  # what is there is whole: no output is ever half-written
        assert deik.read_bvh(path).n_frames == 39
    again = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    for sidecar in finished:
        assert f"{sidecar[1:].removesuffix('.deik.json')}  39      skipped (up to date)" in again.stdout
    assert f"4 clips: {4 - len(finished)} done, {len(finished)} skipped" in again.stdout
    assert sorted(os.listdir(out)) == sorted(
        name for k in range(4) for name in (f"humanoid3d_walk_{k}.bvh", f".humanoid3d_walk_{k}.bvh.deik.json")
    )


def test_the_folder_flags_mistakes_get_one_line(tmp_path, capsys):
    clip = tmp_path / "one.bvh"
    clip.write_text("x")
    assert main(["clip", str(clip), "--out", str(tmp_path / "o.bvh"), "--workers", "2"]) == 2
    assert "--workers: for a folder of clips; " in capsys.readouterr().err
    assert main(["clip", str(tmp_path), "--out", str(tmp_path)]) == 2
    assert "is the folder of the input clips; write the outputs to another folder" in capsys.readouterr().err
    assert main(["clip", str(tmp_path), "--out", str(clip)]) == 2
    assert (
        "--out" in (err := capsys.readouterr().err) and "is a file; with a folder of clips, --out names a folder" in err
    )
    assert main(["clip", str(tmp_path), "--out", str(tmp_path / "o"), "--address", "auto"]) == 2
    assert "--address names a Ray cluster: give it with --executor ray" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["clip", str(empty), "--out", str(tmp_path / "o")]) == 2
    assert "no .bvh clips in this folder" in capsys.readouterr().err
    argv = ["retarget", str(tmp_path), "--scale", "LeftHip=1.1", "--out", str(tmp_path / "o")]
    assert main(argv + ["--view", str(tmp_path / "o")]) == 2
    assert "--out and --view would both write one.bvh" in capsys.readouterr().err
    assert (
        main(["retarget", str(tmp_path), "--map", str(tmp_path / "nomap.toml"), "--to", "humanoid", "--out", "o"]) == 2
    )
    assert "nomap.toml" in capsys.readouterr().err


TOY_CLIP = (ROOT / "benchmarks/fuzz_seeds/seed.bvh").read_text().replace("JOINT Leg", "JOINT LeftFoot")  # a foot


def test_a_rerun_follows_every_reach_track_ignores_how_it_is_shown_and_keeps_reports_apart(tmp_path, capsys):
    clips = tmp_path / "clips"
    clips.mkdir()
    for name in ("a.bvh", "a.deik.bvh"):  # a.deik.bvh's report a.deik.json once shared a.bvh's record
        (clips / name).write_text(TOY_CLIP)
    track = tmp_path / "track"  # a track file whose name ends in neither .csv nor .json
    track.write_text("frame,x,y,z\n0,0,1.4,0.1\n")
    out = tmp_path / "out"
    argv = ["clip", str(clips), "--out", str(out), "--json", str(out), "--reach", f"Spine_end={track}"]
    argv += ["--workers", "1", "--quiet"]
    assert main(argv) == 0
    assert "2 clips: 2 done" in capsys.readouterr().out
    reports = {name: (out / name).read_text() for name in ("a.json", "a.deik.json")}
    assert all(json.loads(text)["frames"] == 3 for text in reports.values())
    for shown in ([], ["--verbose"], ["--progress"]):  # how a run is shown is no setting
        assert main(argv[:-1] + shown) == 0
        assert "2 clips: 0 done, 2 skipped" in capsys.readouterr().out
    assert {name: (out / name).read_text() for name in reports} == reports
    track.write_text("frame,x,y,z\n1,0,1.4,0.1\n")  # the track changed: both clips are redone
    assert main(argv) == 0
    assert "2 clips: 2 done, 0 skipped" in capsys.readouterr().out


def test_a_library_output_that_is_an_input_is_refused_before_any_work(tmp_path, capsys):
    clips, reports = tmp_path / "clips", tmp_path / "reports"
    clips.mkdir()
    reports.mkdir()
    (clips / "a.bvh").write_text(TOY_CLIP)
    track = reports / "a.json"  # clip a.bvh's --json report would replace its own reach track
    track.write_text('[{"frame": 0, "x": 0, "y": 1.4, "z": 0.1}]')
    argv = ["clip", str(clips), "--out", str(tmp_path / "out"), "--json", str(reports)]
    assert main(argv + ["--reach", f"Spine_end={track}", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: --json: ") and "is also an input of the command" in err
    assert err.count("\n") == 1 and json.loads(track.read_text())[0]["frame"] == 0


@pytest.mark.parametrize(
    "extra",
    [
        ["--workers", "-2"],
        ["--workers", "0"],
        ["--json", "INPUTS"],  # the clips' own folder, checked after --out's
        ["--scale", "Spine=1.1", "--view", "OUT"],  # two outputs into one folder
    ],
)
def test_a_refused_folder_run_creates_no_output_folder(tmp_path, capsys, extra):
    clips = tmp_path / "clips"
    clips.mkdir()
    (clips / "a.bvh").write_text(TOY_CLIP)
    out = tmp_path / "out"
    command = "retarget" if "--view" in extra else "clip"
    extra = [str(clips) if word == "INPUTS" else str(out) if word == "OUT" else word for word in extra]
    assert main([command, str(clips), "--out", str(out), *extra, "--quiet"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clips"]


def test_more_workers_than_clips_start_one_per_clip(tmp_path, capsys):
    clips = tmp_path / "clips"
    clips.mkdir()
    for name in ("a.bvh", "b.bvh"):
        (clips / name).write_text(TOY_CLIP)
    assert main(["clip", str(clips), "--out", str(tmp_path / "out"), "--workers", "1000", "--quiet"]) == 0
    assert "on 2 local workers" in capsys.readouterr().out
