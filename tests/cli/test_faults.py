"""Faults injected into real `deik` processes: SIGKILL between a command's final moves, a full
disk (a file-size limit, RLIMIT_FSIZE, makes every write past it fail as a full disk does), a
symlink planted where a temporary file would go, and a legal 255-byte output name. Each command
ends in its whole output set, or none of it and one line naming the file, never a traceback
or a half-written set."""

import json
import os
import resource
import signal
import subprocess
import sys

import pytest

import deik
from deik.cli.app import main
from deik.io import atomic
from helpers import kill_when_ready, shared_path

SOLVE = ["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--generations", "3", "--quiet"]


def _deik(argv) -> list[str]:
    """The command line that runs `deik ARGV` in a fresh process."""
    code = "import sys; from deik.cli import main; sys.exit(main(sys.argv[1:]))"
    return [sys.executable, "-c", code, *map(str, argv)]


@pytest.mark.skipif(not hasattr(resource, "RLIMIT_FSIZE"), reason="needs RLIMIT_FSIZE")
def test_a_full_disk_ends_in_one_line_naming_the_file_and_keeps_the_old_outputs(tmp_path):
    out, picture = tmp_path / "pose.json", tmp_path / "pose.png"
    out.write_text("old pose\n")

    def full_disk():  # writes past 2 kB fail with EFBIG, as they would with ENOSPC on a full disk
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (2048, 2048))

    command = _deik(SOLVE + ["--out", out, "--plot", picture])
    run = subprocess.run(command, capture_output=True, text=True, timeout=600, preexec_fn=full_disk)
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("deik: error: ") and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert "cannot write it: File too large" in run.stderr and str(tmp_path) in run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pose.json"] and out.read_text() == "old pose\n"


def test_a_reader_that_stops_early_loses_no_output(tmp_path):
    """`deik solve ... --out pose.json | head -0`: the pose is written before the table is
    printed, so the reader leaving (exit 141, as for any command whose pipe closes) loses nothing."""
    out = tmp_path / "pose.json"
    read, write = os.pipe()
    os.close(read)  # the reader has gone before the first line
    try:
        run = subprocess.run(
            _deik(SOLVE + ["--out", out]), stdout=write, stderr=subprocess.PIPE, text=True, timeout=600
        )
    finally:
        os.close(write)
    assert run.returncode == 141 and run.stderr == "", run.stderr
    pose = json.loads(out.read_text())
    assert len(pose["angles"]) == 3


@pytest.mark.shared_data
@pytest.mark.parametrize("command", ["clip", "retarget"])
def test_clip_and_retarget_write_everything_before_a_reader_can_leave(tmp_path, command):
    walk = shared_path("humanoid", "humanoid3d_walk.bvh")
    out, report = tmp_path / "out.bvh", tmp_path / "report.json"
    extra = [] if command == "clip" else ["--scale", "LeftKnee=1.1,RightKnee=1.1"]
    read, write = os.pipe()
    os.close(read)
    try:
        argv = [command, walk, "--out", out, "--json", report, *extra]
        run = subprocess.run(_deik(argv), stdout=write, stderr=subprocess.PIPE, text=True, timeout=600)
    finally:
        os.close(write)
    assert run.returncode == 141 and "Traceback" not in run.stderr, run.stderr
    assert deik.read_bvh(out).n_frames == deik.read_bvh(walk).n_frames and json.loads(report.read_text())


KILLED_BETWEEN_MOVES = """
import os, sys, time
from deik.io import atomic
from deik.cli import main

real, ready = os.replace, sys.argv[1]

def replace(source, target):  # pause after the first output is in place: the kill comes then
    real(source, target)
    if not os.path.basename(target).startswith(atomic.JOURNAL) and not os.path.exists(ready):
        open(ready, "w").close()
        time.sleep(120)

atomic.os.replace = replace
sys.exit(main(sys.argv[2:]))
"""


def test_a_solve_killed_between_its_moves_is_completed_by_the_next_command(tmp_path):
    out, picture = tmp_path / "pose.json", tmp_path / "pose.png"
    out.write_text('{"old": true}\n')
    ready = tmp_path / "ready"
    argv = [str(a) for a in SOLVE + ["--out", out, "--plot", picture]]
    kill_when_ready(subprocess.Popen([sys.executable, "-c", KILLED_BETWEEN_MOVES, str(ready), *argv]), ready)
    journals = [p.name for p in tmp_path.iterdir() if p.name.startswith(atomic.JOURNAL)]
    assert len(journals) == 1  # the commit was under way: one file moved, the other still to go
    # the next deik command reading in the folder completes the set before it reads
    command = _deik(["solve", "--problem", tmp_path / "missing.toml"])
    subprocess.run(command, capture_output=True, timeout=300)  # reads in the folder (a missing file)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pose.json", "pose.png", "ready"]
    pose = json.loads(out.read_text())
    assert "old" not in pose and len(pose["angles"]) == 3
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_symlink_planted_at_a_temporary_name_is_not_followed(tmp_path, monkeypatch, capsys):
    outside = tmp_path / "outside"
    outside.mkdir()
    victim = outside / "precious.txt"
    victim.write_text("keep me\n")
    folder = tmp_path / "out"
    folder.mkdir()
    tokens = iter(["0badc0de"] * 3 + [f"{k:08x}" for k in range(100)])
    monkeypatch.setattr(atomic.secrets, "token_hex", lambda n: next(tokens))
    planted = folder / f"{atomic.PARTIAL}{atomic.HOST}-{os.getpid()}-0badc0de.pose.json"
    planted.symlink_to(victim)
    assert main(SOLVE + ["--out", str(folder / "pose.json")]) == 0
    assert victim.read_text() == "keep me\n" and not (folder / "pose.json").is_symlink()
    assert json.loads((folder / "pose.json").read_text())["angles"]


def test_a_255_byte_output_name_is_written(tmp_path):
    name = "p" * 250 + ".json"
    assert main(SOLVE + ["--out", str(tmp_path / name)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_temporaries_of_a_killed_command_are_removed_by_the_next_one(tmp_path):
    stranded = tmp_path / f"{atomic.PARTIAL}{atomic.HOST}-999999999-0123abcd.pose.json"
    stranded.write_text("{ half")
    assert main(SOLVE + ["--out", str(tmp_path / "pose.json")]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["pose.json"]
