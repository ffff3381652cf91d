"""deik.library on a task the tests control (helpers.library_task): which files of a folder are
clips, fingerprints that change with every setting, input byte and output, skipping what is
done, a failed clip that stops no other, and a worker killed mid-clip that fails only its clip
while a rerun redoes it and skips the rest. Local worker processes are real (spawned)."""

import json
import os
import signal
import sys
import threading
import time

import pytest

from deik.library.folder import find_clips, output_folder
from deik.library.jobs import Job, fingerprint, read_sidecar, sidecar_path
from deik.library.local import default_workers, threads_per_worker
from deik.library.run import run_library, summary_line, summary_table
from helpers import library_task


def _jobs(folder, out, names, text="made", modes=None, settings=None):
    """One Job per clip name, its output OUT/STEM.txt, a payload for helpers.library_task."""
    jobs = []
    for name in names:
        source = folder / name
        if not source.exists():
            source.write_text(f"clip {name}\n")
        outputs = (str(out / (source.stem + ".txt")),)
        payload = {"outputs": outputs, "text": text, "mode": (modes or {}).get(name), "pid_file": str(out / "pid")}
        settings = settings or {"text": text}
        key = fingerprint("test", settings, source, {}, outputs)
        jobs.append(Job(name, str(source), outputs, sidecar_path(out, name), key, settings, payload))
    return jobs


def test_a_folder_lists_its_bvh_files_and_says_what_it_skips(tmp_path):
    for name in ("b.bvh", "a.BVH", "notes.txt", ".hidden.bvh", "a.segments.json"):
        (tmp_path / name).write_text("x")
    (tmp_path / "more.bvh").mkdir()
    clips, skipped = find_clips(tmp_path)
    assert [os.path.basename(p) for p in clips] == ["a.BVH", "b.bvh"]
    assert sorted(skipped) == [".hidden.bvh", "a.segments.json", "more.bvh", "notes.txt"]
    (tmp_path / "a.bvh").write_text("x")  # a.bvh and a.BVH would write the same outputs
    with pytest.raises(ValueError, match="a.BVH and a.bvh would write the same outputs; rename"):
        find_clips(tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no .bvh clips in this folder.*it is empty"):
        find_clips(empty)


def test_output_folders_are_made_but_never_the_input_folder_or_a_file(tmp_path):
    made = output_folder("--out", str(tmp_path / "out"), str(tmp_path))
    assert os.path.isdir(made)
    with pytest.raises(ValueError, match="--out .* is the folder of the input clips"):
        output_folder("--out", str(tmp_path), str(tmp_path))
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="--json .* is a file; with a folder of clips, --json names a folder"):
        output_folder("--json", str(tmp_path / "file"), str(tmp_path / "out"))
    with pytest.raises(ValueError, match="does not exist; create it first"):
        output_folder("--out", str(tmp_path / "no" / "out"), str(tmp_path))


def test_the_fingerprint_follows_settings_input_bytes_named_files_and_outputs(tmp_path):
    source, table = tmp_path / "a.bvh", tmp_path / "limits.json"
    source.write_text("clip")
    table.write_text("{}")
    base = fingerprint("clip", {"seed": 1}, source, {"limits": table}, ["o/a.bvh"])
    assert fingerprint("clip", {"seed": 1}, source, {"limits": table}, ["o/a.bvh"]) == base
    assert fingerprint("clip", {"seed": 2}, source, {"limits": table}, ["o/a.bvh"]) != base
    assert fingerprint("retarget", {"seed": 1}, source, {"limits": table}, ["o/a.bvh"]) != base
    assert fingerprint("clip", {"seed": 1}, source, {"limits": table}, ["p/a.bvh"]) != base
    table.write_text('{"LeftKnee": [0, 90]}')
    assert fingerprint("clip", {"seed": 1}, source, {"limits": table}, ["o/a.bvh"]) != base
    table.write_text("{}")
    source.write_text("clap")
    assert fingerprint("clip", {"seed": 1}, source, {"limits": table}, ["o/a.bvh"]) != base


def test_a_rerun_skips_what_is_done_and_redoes_a_changed_setting_or_a_lost_output(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    jobs = _jobs(tmp_path, out, ["a.bvh", "b.bvh"])
    first = run_library(jobs, library_task, workers=2, quiet=True)
    assert [o.status for o in first.outcomes] == ["done", "done"]
    assert (out / "a.txt").read_text() == "made" and read_sidecar(jobs[0])[0]["record"]["frames"] == 2
    assert first.frames_done() == 4 and "2 clips: 2 done, 0 skipped" in summary_line(first)
    again = run_library(jobs, library_task, workers=2, quiet=True)
    assert [o.status for o in again.outcomes] == ["skipped", "skipped"]
    assert again.outcomes[0].record["frames"] == 2  # the sidecar's record, shown in the table
    assert "skipped (up to date)" in summary_table(again, [("pid", lambda r: str(r["metrics"]["pid"]))])
    os.unlink(out / "b.txt")
    changed = run_library(_jobs(tmp_path, out, ["a.bvh", "b.bvh"], text="other"), library_task, quiet=True)
    assert [o.status for o in changed.outcomes] == ["done", "done"]
    assert (out / "a.txt").read_text() == "other"
    lost = _jobs(tmp_path, out, ["a.bvh", "b.bvh"], text="other")
    os.unlink(out / "b.txt")
    assert [o.status for o in run_library(lost, library_task, quiet=True).outcomes] == ["skipped", "done"]


def test_a_failed_clip_is_reported_and_stops_no_other(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    jobs = _jobs(tmp_path, out, ["a.bvh", "b.bvh", "c.bvh"], modes={"b.bvh": "fail"})
    lines = []
    run = run_library(jobs, library_task, workers=1, quiet=True, note=lines.append)
    assert [o.status for o in run.outcomes] == ["done", "failed", "done"]
    assert run.outcomes[1].reason == "this clip is broken on purpose"
    assert lines == ["deik: b.bvh: failed: this clip is broken on purpose"]
    assert not (out / "b.txt").exists() and not os.path.exists(jobs[1].sidecar)
    assert "1 failed" in summary_line(run)


def _kill_when_hanging(pid_file, killed: list):
    """Wait for the hanging job to write its worker's process id, then kill that worker."""
    for _ in range(600):
        if os.path.exists(pid_file):
            pid = int(open(pid_file).read())
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
            return
        time.sleep(0.05)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL is POSIX")
def test_a_killed_worker_fails_its_clip_only_and_a_rerun_redoes_it(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    names = ["a.bvh", "b.bvh", "c.bvh", "d.bvh"]
    jobs = _jobs(tmp_path, out, names, modes={"b.bvh": "hang"})
    killed = []
    killer = threading.Thread(target=_kill_when_hanging, args=(str(out / "pid"), killed))
    killer.start()
    run = run_library(jobs, library_task, workers=2, quiet=True, note=lambda line: None)
    killer.join()
    assert killed, "the hanging job never started"
    statuses = {o.job.name: o.status for o in run.outcomes}
    assert statuses == {"a.bvh": "done", "b.bvh": "failed", "c.bvh": "done", "d.bvh": "done"}
    assert "killed (SIGKILL)" in run.outcomes[1].reason
    pids = {o.record["metrics"]["pid"] for o in run.outcomes if o.record}
    assert killed[0] not in pids  # the clips after the kill ran on the other or a new worker
    # the rerun, with the clip repaired, redoes only the killed one
    rerun = run_library(_jobs(tmp_path, out, names), library_task, workers=2, quiet=True)
    assert [o.status for o in rerun.outcomes] == ["skipped", "done", "skipped", "skipped"]
    assert sorted(os.listdir(out)) == sorted(
        ["pid"] + [f"{n[0]}.txt" for n in names] + [f".{n}.deik.json" for n in names]
    )


def test_workers_share_out_the_cores():
    assert default_workers(jobs=8, cores=2) == 2 and default_workers(jobs=1, cores=16) == 1
    assert threads_per_worker(2, cores=2) == 1 and threads_per_worker(1, cores=2) == 2
    assert threads_per_worker(3, cores=16) == 5  # workers x threads never above the cores


def test_bad_executor_choices_say_what_to_do(tmp_path, monkeypatch):
    jobs = _jobs(tmp_path, tmp_path, ["a.bvh"])
    with pytest.raises(ValueError, match="executor 'dask': use local or ray"):
        run_library(jobs, library_task, executor="dask")
    with pytest.raises(ValueError, match="workers 0: use a whole number >= 1"):
        run_library(jobs, library_task, workers=0)
    with pytest.raises(ValueError, match="an address names a Ray cluster"):
        run_library(jobs, library_task, address="auto")
    monkeypatch.setitem(sys.modules, "ray", None)  # as without the extra installed
    with pytest.raises(ImportError, match=r'pip install "deik\[ray\]"'):
        run_library(jobs, library_task, executor="ray")


def test_a_ray_that_cannot_start_is_said_so_not_called_a_bug(tmp_path, monkeypatch):
    ray = pytest.importorskip("ray", reason='Ray is an optional extra (pip install "deik[ray]"): not installed here')
    from deik.errors import SolveError

    def timed_out(**options):  # what ray.init raises when its processes start too slowly (a memory cap)
        raise RuntimeError(
            "The current node timed out during startup. This could happen because some of the Ray "
            "processes failed to startup.\nsee the logs"
        )

    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", timed_out)
    jobs = _jobs(tmp_path, tmp_path, ["a.bvh"])
    with pytest.raises(SolveError, match=r"the Ray executor could not start Ray on this machine \(.*timed out"):
        run_library(jobs, library_task, executor="ray", quiet=True)


def test_ray_runs_the_same_jobs_on_a_local_instance(tmp_path, monkeypatch):
    pytest.importorskip("ray", reason='Ray is an optional extra (pip install "deik[ray]"): not installed here')
    # Ray's workers import the task by name: the instance started here passes them this path
    tests = os.path.dirname(os.path.abspath(library_task.__code__.co_filename))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [tests, os.environ.get("PYTHONPATH")])))
    out = tmp_path / "out"
    out.mkdir()
    jobs = _jobs(tmp_path, out, ["a.bvh", "b.bvh", "c.bvh"], modes={"c.bvh": "fail"})
    run = run_library(jobs, library_task, executor="ray", quiet=True, note=lambda line: None)
    assert [o.status for o in run.outcomes] == ["done", "done", "failed"]
    assert run.outcomes[2].reason == "this clip is broken on purpose"
    assert (out / "a.txt").read_text() == "made" and read_sidecar(jobs[1])[0] is not None
    assert "on Ray" in summary_line(run)
    again = run_library(jobs[:2], library_task, executor="ray", quiet=True)
    assert [o.status for o in again.outcomes] == ["skipped", "skipped"]


DAMAGED = {
    "deeply nested": lambda path: path.write_text("[" * 100_000 + "]" * 100_000),
    "nested past the bound": lambda path: path.write_text("[" * 40 + "]" * 40),
    "not JSON": lambda path: path.write_text("{"),
    "a link to /dev/zero": lambda path: path.symlink_to("/dev/zero"),
    "a FIFO": lambda path: os.mkfifo(path),
    "a wrong-typed field": lambda path: path.write_text(json.dumps(_sidecar(path, frames="two"))),
    "a wrong-typed metric": lambda path: path.write_text(json.dumps(_sidecar(path, metrics={"pid": "x"}))),
    "a 400-digit number": lambda path: path.write_text(json.dumps({**_sidecar(path), "seconds": 10**400})),
    "a folder": lambda path: path.mkdir(),
}


def _sidecar(path, **record):
    """The sidecar the rerun's job expects (its fingerprint is read back from the good one) with
    `record` fields changed."""
    good = json.loads(path.with_name(path.name + ".good").read_text())
    good["record"].update(record)
    return good


@pytest.mark.parametrize("damage", DAMAGED)
def test_a_damaged_sidecar_redoes_its_clip_and_says_so(tmp_path, damage):
    out = tmp_path / "out"
    out.mkdir()
    jobs = _jobs(tmp_path, out, ["a.bvh", "b.bvh"])
    assert [o.status for o in run_library(jobs, library_task, quiet=True).outcomes] == ["done", "done"]
    sidecar = out / ".a.bvh.deik.json"
    good = sidecar.read_text()
    sidecar.with_name(sidecar.name + ".good").write_text(good)
    sidecar.unlink()
    DAMAGED[damage](sidecar)
    lines = []
    rerun = run_library(jobs, library_task, quiet=True, note=lines.append)
    statuses = [o.status for o in rerun.outcomes]
    if damage == "a folder":  # the clip is redone, but its record cannot replace a folder: said
        assert statuses == ["failed", "skipped"] and "its record is not" in rerun.outcomes[0].reason
    else:
        assert statuses == ["done", "skipped"]
        assert json.loads(sidecar.read_text())["record"]["frames"] == 2  # a good record again
    assert lines[0].startswith("deik: a.bvh: its record is damaged (") and lines[0].endswith("; redoing the clip")
    assert str(sidecar) in lines[0]


def test_a_full_disk_while_the_record_is_written_fails_that_clip_with_the_reason(tmp_path, monkeypatch):
    from deik.library import local

    out = tmp_path / "out"
    out.mkdir()
    jobs = _jobs(tmp_path, out, ["a.bvh"])

    def full(job, record, seconds):
        raise OSError(28, "No space left on device", job.sidecar)

    monkeypatch.setattr(local, "write_sidecar", full)
    status, reason, _ = local.attempt(library_task, jobs[0], lambda done, total: None)
    assert status == "failed" and "internal error" not in reason
    assert reason.startswith("its outputs are written but its record is not (") and "No space left on device" in reason


CTRL_C_RUN = """
import sys
from pathlib import Path
sys.path.insert(0, sys.argv[2])
from helpers import library_task
from deik.library.jobs import Job, fingerprint, sidecar_path
from deik.library.run import run_library

folder = Path(sys.argv[1])
jobs = []
for name in ("a.bvh", "b.bvh"):
    source = folder / name
    source.write_text("clip")
    outputs = (str(folder / "out" / (source.stem + ".txt")),)
    payload = {"outputs": outputs, "text": "x", "mode": "hang", "pid_file": str(folder / "out" / f"{name}.pid")}
    key = fingerprint("test", {}, source, {}, outputs)
    jobs.append(Job(name, str(source), outputs, sidecar_path(folder / "out", name), key, {}, payload))
try:
    run_library(jobs, library_task, workers=2, quiet=True)
except KeyboardInterrupt:
    print("interrupted", file=sys.stderr)
    sys.exit(130)
"""


def _busy_workers(run, out) -> list[int]:
    """The process ids of the two workers of the script `run` (CTRL_C_RUN), once both hold a job
    (each writes its pid into the folder `out`)."""
    deadline = time.monotonic() + 120
    while len(list(out.glob("*.pid"))) < 2:
        assert run.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    return [int(path.read_text()) for path in out.glob("*.pid")]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_ctrl_c_ends_busy_workers_at_once_and_leaves_no_warning(tmp_path):
    import subprocess

    (tmp_path / "out").mkdir()
    tests = os.path.dirname(os.path.abspath(__file__)).rsplit(os.sep, 1)[0]
    run = subprocess.Popen(  # -c: the spawned workers do not run the script again as their __main__
        [sys.executable, "-c", CTRL_C_RUN, str(tmp_path), tests],
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        workers = _busy_workers(run, tmp_path / "out")
        for pid in workers:  # a worker ignores SIGINT from its first instruction: the parent stops it
            os.kill(pid, signal.SIGINT)
        time.sleep(4.0)  # a worker that took it for Ctrl-C had ended by now
        assert all(map(_running, workers))
        os.killpg(run.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group, workers included
        status = run.wait(timeout=60)
    finally:
        run.kill()
    err = run.stderr.read()
    assert status == 130 and err == "interrupted\n", err  # no traceback, no leaked-semaphore warning
    assert not any(map(_running, workers))


SIGTERM_RUN = CTRL_C_RUN.replace(
    "try:\n    run_library(jobs, library_task, workers=2, quiet=True)",
    "from deik.cli.folder_command import _terminate_as_interrupt\n"
    "try:\n    with _terminate_as_interrupt():\n        run_library(jobs, library_task, workers=2, quiet=True)",
)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_to_a_folder_run_ends_its_workers_as_ctrl_c_does(tmp_path):
    """`kill PID` on a folder run ended the parent at once and left its busy workers running,
    their parent now init; `deik clip FOLDER` handles it as Ctrl-C (folder_command)."""
    import subprocess

    assert SIGTERM_RUN != CTRL_C_RUN
    (tmp_path / "out").mkdir()
    tests = os.path.dirname(os.path.abspath(__file__)).rsplit(os.sep, 1)[0]
    run = subprocess.Popen([sys.executable, "-c", SIGTERM_RUN, str(tmp_path), tests], stderr=subprocess.PIPE, text=True)
    try:
        workers = _busy_workers(run, tmp_path / "out")
        run.send_signal(signal.SIGTERM)  # to the parent alone, as `kill PID` sends it
        status = run.wait(timeout=60)
    finally:
        run.kill()
    err = run.stderr.read()
    assert status == 130 and err == "interrupted\n", err
    assert not any(map(_running, workers))


def _running(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, ended but not yet reaped by its parent, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as file:
            return file.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_a_clip_named_up_to_the_file_system_s_limit_keeps_a_record_that_fits(tmp_path):
    """A 252-byte clip name made the record `.NAME.deik.json` 266 bytes: its outputs were
    written, its record could not be, and every rerun redid the clip and failed alike."""
    short, long = "walk.bvh", "c" * 248 + ".bvh"
    for name in (short, long):
        path = sidecar_path(tmp_path, name)
        assert len(os.path.basename(path).encode()) <= 255
        (tmp_path / os.path.basename(path)).write_text("{}")  # a file system takes the name
    assert os.path.basename(sidecar_path(tmp_path, short)) == ".walk.bvh.deik.json"
    assert sidecar_path(tmp_path, long) != sidecar_path(tmp_path, "c" * 247 + "d.bvh")  # whole name in the digest
