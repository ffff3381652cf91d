"""Run a library: skip the jobs already done, run the rest on local workers or Ray with a
progress bar over clips and one over frames, and summarise.

    run = run_library(jobs, task, executor="local", workers=2)
    print(summary_table(run, columns)); print(summary_line(run))

`task(payload, progress) -> record` is a module-level function (it travels to the workers by
name): it does one clip, calls `progress(done, total)` with frames, raises JobFailed with a
one-line reason for a clip it cannot do, and returns a JSON-able record holding at least
`frames`. Jobs run longest input first, so the last clips to finish are short.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from deik.errors import InputError
from deik.library.jobs import Job, Outcome, Task, skipped
from deik.library.local import default_workers, local_events, threads_per_worker
from deik.library.ray_cluster import ray_events, require_ray
from deik.viz.text import format_table

EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class LibraryRun:
    """The outcome of run_library: `outcomes` one per job in the jobs' order, `wall_time`
    seconds, `executor`, `workers` (local processes, or Ray tasks in flight; None: as many as
    the cluster takes) and `threads` per worker."""

    outcomes: tuple[Outcome, ...]
    wall_time: float
    executor: str
    workers: int | None
    threads: int

    def count(self, status: str) -> int:
        return sum(outcome.status == status for outcome in self.outcomes)

    def frames_done(self) -> int:
        """Frames of the clips done in this run (not the skipped)."""
        return sum(int(o.record.get("frames", 0)) for o in self.outcomes if o.status == "done" and o.record)


def _events(jobs, task, executor: str, workers: int | None, address: str | None):
    """(events, workers, threads) of the executor."""
    if executor == "local":
        workers = min(workers, len(jobs)) if workers else default_workers(len(jobs))  # one clip a worker at most
        threads = threads_per_worker(workers)
        return local_events(jobs, task, workers, threads), workers, threads
    return ray_events(jobs, task, address, workers and min(workers, len(jobs))), workers, 1


def _check(executor: str, workers, address) -> None:
    """ValueError or ImportError (with the fix) for a bad executor choice, before any work."""
    if executor not in EXECUTORS:
        raise InputError(f"executor {executor!r}: use {' or '.join(EXECUTORS)}")
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise InputError(f"workers {workers!r}: use a whole number >= 1")
    if address is not None and executor != "ray":
        raise InputError("an address names a Ray cluster: give it with the ray executor (--executor ray)")
    if executor == "ray":
        require_ray()


def run_library(
    jobs: Sequence[Job],
    task: Task,
    *,
    executor: str = "local",
    workers: int | None = None,
    address: str | None = None,
    quiet: bool = False,
    note: Callable[[str], object] | None = None,
    progress: bool = False,
) -> LibraryRun:
    """Run every job of `jobs` that is not done yet (jobs.read_sidecar) with `task`, on
    `executor` "local" (`workers` processes, default one per core) or "ray" (`address` of the
    cluster, default a local instance; `workers` tasks in flight at most). Progress bars go to
    stderr when it is a terminal, or always with `progress`, never when `quiet`; `note(line)`
    is called with a line for each failed clip as it fails (default: printed on stderr, above
    the bars)."""
    _check(executor, workers, address)
    began = time.perf_counter()
    outcomes, pending = {}, []
    say = note or (lambda line: print(line, file=sys.stderr))
    for job in jobs:
        done, damage = skipped(job)
        if damage:
            say(f"deik: {job.name}: {damage}")
        if done is None:
            pending.append(job)
        else:
            outcomes[job.name] = done
    threads = 1
    if pending:
        pending.sort(key=lambda job: -os.path.getsize(job.source))
        events, workers, threads = _events(pending, task, executor, workers, address)
        show = False if quiet else (True if progress else None)  # None: on a terminal only
        _follow(events, len(jobs), len(jobs) - len(pending), outcomes, show, note)
    ordered = tuple(outcomes[job.name] for job in jobs)
    return LibraryRun(ordered, time.perf_counter() - began, executor, workers if pending else 0, threads)


def _follow(events, total: int, initial: int, outcomes: dict, show: bool | None, note) -> None:
    """Consume `events`, recording each finished Outcome in `outcomes` and drawing the bars
    (`show` True always, None when stderr is a terminal, False never)."""
    from tqdm import tqdm

    bars = dict(file=sys.stderr, disable=None if show is None else not show, dynamic_ncols=True)
    with (
        tqdm(total=total, initial=initial, desc="clips", unit="clip", position=0, **bars) as clips,
        tqdm(total=0, desc="frames", unit="frame", position=1, **bars) as frames,
    ):
        say = note or (lambda line: clips.write(line, file=sys.stderr))
        running, finished = {}, 0  # running: job name -> (frames done, frames in the clip)
        for event in events:
            if event[0] == "started":
                running[event[1].name] = (0, 0)
            elif event[0] == "progress":
                running[event[1].name] = (int(event[2]), int(event[3]))
            else:
                outcome = event[1]
                outcomes[outcome.job.name] = outcome
                _, total_frames = running.pop(outcome.job.name, (0, 0))
                finished += int((outcome.record or {}).get("frames", total_frames))
                clips.update(1)
                if outcome.status == "failed":
                    say(f"deik: {outcome.job.name}: failed: {outcome.reason}")
            frames.total = finished + sum(t for _, t in running.values())
            frames.n = finished + sum(d for d, _ in running.values())
            frames.refresh()
            clips.set_postfix_str(", ".join(running), refresh=True)


def summary_table(run: LibraryRun, columns: Sequence[tuple[str, Callable[[dict], str]]]) -> str:
    """One row per clip: its name, frames, status, time (s) and `columns` [(header, pick)]
    where pick(record) gives the cell ("-" when the clip has no record)."""
    header = ["clip", "frames", "status", "time s", *(name for name, _ in columns)]
    rows = []
    for outcome in run.outcomes:
        record = outcome.record or {}
        status = {"skipped": "skipped (up to date)"}.get(outcome.status, outcome.status)
        cells = [pick(record) if record else "-" for _, pick in columns]
        time_cell = f"{outcome.seconds:.2f}" if outcome.status != "failed" or outcome.seconds else "-"
        rows.append([outcome.job.name, record.get("frames", "-"), status, time_cell, *cells])
    return format_table(header, rows)


def summary_line(run: LibraryRun) -> str:
    """The totals: clips done, skipped and failed, frames and clips per second of wall time."""
    done, frames = run.count("done"), run.frames_done()
    line = (
        f"{len(run.outcomes)} clips: {done} done, {run.count('skipped')} skipped (done before with the same "
        f"settings and input), {run.count('failed')} failed"
    )
    if done:
        where = (
            f"{run.workers} local worker{'s' if run.workers != 1 else ''} x {run.threads} thread"
            f"{'s' if run.threads != 1 else ''}"
            if run.executor == "local"
            else "Ray"
        )
        line += (
            f"; {frames} frames in {run.wall_time:.1f} s ({frames / run.wall_time:.1f} frames/s, "
            f"{done / run.wall_time:.2f} clips/s) on {where}"
        )
    return line
