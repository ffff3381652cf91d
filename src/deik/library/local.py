"""Local worker processes for a library: each runs one job at a time, and a worker that dies
(killed, out of memory) fails only the job it held; a fresh worker takes the rest.

Workers are spawned (a fork of a process whose Numba threads run is unsafe) with Numba, OpenMP
and BLAS limited to `threads` each, so workers x threads stays within the cores. Each talks to
the parent over its own pipe: the parent knows which job every worker holds, which a pool
(concurrent.futures breaks whole when one worker dies) would not tell.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Iterable, Iterator
from multiprocessing.connection import wait

from deik.errors import error_line
from deik.library.jobs import Event, FrameProgress, Job, JobFailed, Outcome, Task, write_sidecar

THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
STOP_WAIT_S = 5.0  # how long workers get to exit after Ctrl-C before they are killed


def default_workers(jobs: int, cores: int | None = None) -> int:
    """One worker per core, at most one per job (at least 1)."""
    return max(1, min(jobs, cores or os.cpu_count() or 1))


def threads_per_worker(workers: int, cores: int | None = None) -> int:
    """The cores shared out among `workers` (at least 1 each)."""
    return max(1, (cores or os.cpu_count() or 1) // max(workers, 1))


def perform(task: Task, job: Job, progress: FrameProgress) -> tuple[dict, float]:
    """Run `task(job.payload, progress)` and record the job as done: (record, seconds)."""
    began = time.perf_counter()
    record = task(job.payload, progress)
    seconds = time.perf_counter() - began
    try:
        write_sidecar(job, record, seconds)
    except OSError as error:  # a full disk, or a folder where the record goes: the user's to fix
        raise JobFailed(
            f"its outputs are written but its record is not ({error_line(error)}); fix that and rerun "
            "(the clip is redone)"
        ) from None
    return record, seconds


def attempt(task: Task, job: Job, progress: FrameProgress) -> tuple:
    """("done", record, seconds) or ("failed", reason, seconds) of one job; KeyboardInterrupt
    passes."""
    began = time.perf_counter()
    try:
        record, seconds = perform(task, job, progress)
        return "done", record, seconds
    except JobFailed as failure:
        return "failed", str(failure.args[0]), time.perf_counter() - began
    except Exception as error:  # a bug in the task: reported with the job, the others go on
        return "failed", f"internal error: {type(error).__name__}: {error}", time.perf_counter() - began


def _serve(connection, task) -> None:
    """A worker's loop: take a job, send progress and its outcome, until told to stop or the
    parent has gone. Its progress bars (disabled) lock with a thread lock: tqdm's default
    process-shared lock is a named semaphore, leaked (and warned about at exit) when a
    worker is ended mid-clip after Ctrl-C."""
    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())
    signal.signal(signal.SIGTERM, _leave)
    with contextlib.suppress(EOFError, BrokenPipeError):
        while (job := connection.recv()) is not None:
            status, value, seconds = attempt(task, job, lambda done, total: connection.send(("progress", done, total)))
            connection.send((status, value, seconds))


@contextlib.contextmanager
def _environment(values: dict):
    """os.environ with `values` set inside the block (a spawned process inherits it)."""
    saved = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _leave(signum: int, frame: object) -> None:
    """A worker's SIGTERM: exit through Python's unwinding, so that an all_or_nothing block of the
    clip it holds removes its temporary files (deik.io.atomic)."""
    raise SystemExit(128 + signum)


@contextlib.contextmanager
def _without_ctrl_c():
    """SIGINT ignored inside the block, so that a process started in it ignores Ctrl-C from its
    first instruction (an ignored signal stays ignored across exec, and Python then installs no
    KeyboardInterrupt): Ctrl-C is the parent's to handle, which stops its workers; a worker
    interrupted while importing or compiling printed tracebacks and leaked semaphores."""
    if threading.current_thread() is not threading.main_thread():  # only the main thread sets handlers
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class _Worker:
    """A worker process, the parent's end of its pipe and the job it holds (or None)."""

    def __init__(self, context, task, threads: int):
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, task), daemon=True, name="deik-library-worker")
        with _environment({key: str(threads) for key in THREAD_VARIABLES}), _without_ctrl_c():
            self.process.start()
        child.close()
        self.job = None

    def death(self) -> str:
        """Why the process ended, in words."""
        code = self.process.exitcode
        if code is not None and code < 0:
            with contextlib.suppress(ValueError):
                return f"its worker process was killed ({signal.Signals(-code).name}); rerun to redo it"
        return f"its worker process ended (exit status {code}); rerun to redo it"


def local_events(jobs: Iterable[Job], task: Task, workers: int, threads: int) -> Iterator[Event]:
    """Run `jobs` on `workers` local processes of `threads` threads each; yield ("started",
    job), ("progress", job, done, total) and ("finished", Outcome) events as they happen."""
    context = multiprocessing.get_context("spawn")
    waiting, pool = deque(jobs), []
    try:
        while waiting or any(worker.job for worker in pool):
            while waiting and len(pool) < workers:
                pool.append(_Worker(context, task, threads))
            for worker in pool:
                if worker.job is None and waiting:
                    worker.job = waiting.popleft()
                    worker.connection.send(worker.job)
                    yield ("started", worker.job)
            wait([worker.connection for worker in pool] + [worker.process.sentinel for worker in pool])
            for worker in list(pool):
                alive = worker.process.is_alive()  # before draining: a dead worker's last words are read
                yield from _drain(worker)
                if not alive:
                    pool.remove(worker)
                    if worker.job is not None:
                        yield ("finished", Outcome(worker.job, "failed", reason=worker.death()))
    finally:
        _stop(pool)


def _drain(worker: _Worker):
    """The events of every message waiting on `worker`'s pipe, up to its end if it has died."""
    while worker.connection.poll():
        try:
            message = worker.connection.recv()
        except (EOFError, OSError):
            return
        if worker.job is None:
            continue
        if message[0] == "progress":
            yield ("progress", worker.job, *message[1:])
            continue
        status, value, seconds = message
        outcome = Outcome(worker.job, status, seconds, *((value, "") if status == "done" else (None, value)))
        worker.job = None
        yield ("finished", outcome)


def _stop(pool: list) -> None:
    """Tell every idle worker to stop and end every busy one (the run was interrupted: SIGTERM,
    on which a worker removes its temporary files and exits), give them STOP_WAIT_S, then kill
    the rest. A clip cut short is redone by the next run: its record was never written."""
    for worker in pool:
        if worker.job is None:
            with contextlib.suppress(OSError, BrokenPipeError):
                worker.connection.send(None)
        else:
            worker.process.terminate()
    deadline = time.monotonic() + STOP_WAIT_S
    for worker in pool:
        worker.process.join(max(0.0, deadline - time.monotonic()))
        if worker.process.is_alive():
            worker.process.kill()
            worker.process.join(1.0)
        worker.connection.close()
