"""Compiling the CPU kernels a command needs side by side, in worker processes, with a bar that
moves from the first second.

Numba compiles a kernel in one thread, and holds one lock while it does, so two kernels in one
process compile one after the other. A first float32 solve needs two (its DE kernel and the
float64 report), `deik warmup` four: each worker process compiles its share (the longest first,
to the least loaded worker) into the disk cache and reports each kernel's compile seconds, and
this process then loads them, as a later command would. Meanwhile a bar runs over the expected
seconds. Without a writable disk cache, or when a worker fails, this process compiles what is
left itself.

    python -m deik.backends.compiling   (a worker: reads pickled jobs on stdin, prints seconds as JSON)
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NamedTuple

from deik.errors import UsageError

TICK = 0.25  # seconds between the bar's moves
# how much longer a compile takes while another compiles beside it on 2 cores: in `deik warmup`
# the two DE kernels took 22.2-22.3 s of Numba's timer each, against 19.8 for one of them alone
# (two runs of benchmarks/cold_start.py on an idle 2-core AMD EPYC VM: docs/performance.md)
SIDE_BY_SIDE = 1.12


class KernelJob(NamedTuple):
    """One entry point to compile: kernel (a function of deik.backends.cpu_kernels), the build's
    switches, the signature (a tuple of Numba types), its name in notes, and its expected seconds."""

    kernel: str
    build: frozenset
    signature: tuple
    label: str
    seconds: float


def cores() -> int:
    """CPU cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def workers() -> int:
    """Worker processes compile_all may start: DEIK_COMPILE_WORKERS when set (0 or 1: compile in
    this process, as a profile of the compile needs), else one per core."""
    try:
        return int(os.environ.get("DEIK_COMPILE_WORKERS", "").strip() or cores())
    except ValueError:
        raise UsageError(
            "DEIK_COMPILE_WORKERS must be a whole number of processes (0 or 1: compile in this process)"
        ) from None


def shares(jobs: list[KernelJob], workers: int) -> list[list[KernelJob]]:
    """Jobs split among up to `workers` workers: the longest first, each to the least loaded."""
    loads = [[0.0, []] for _ in range(max(1, min(workers, len(jobs))))]
    for job in sorted(jobs, key=lambda j: -j.seconds):
        least = min(loads, key=lambda load: load[0])
        least[0] += job.seconds
        least[1].append(job)
    return [share for _, share in loads if share]


def expected_seconds(jobs: list[KernelJob]) -> float:
    """About how long compile_all takes: its busiest worker's share, slowed by SIDE_BY_SIDE for as
    long as another worker compiles beside it."""
    totals = sorted((sum(j.seconds for j in share) for share in shares(jobs, max(1, workers()))), reverse=True)
    beside = totals[1] if len(totals) > 1 else 0.0
    return (totals[0] if totals else 0.0) + (SIDE_BY_SIDE - 1.0) * beside


@contextmanager
def time_bar(description: str, seconds: float, show: bool | None) -> Iterator[None]:
    """A bar on stderr over about `seconds` that moves with the clock while the body runs (it
    stops short of the end until the body is done); `show` as console.progress_bar's, except that
    on a terminal it appears at once."""
    from deik.console import progress_bar

    total = max(1, round(seconds))
    with progress_bar(total, description, "s", show) as bar:
        if bar.disable:
            yield
            return
        bar.delay = 0.0
        bar.bar_format = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} s expected [{elapsed}]"
        done = threading.Event()

        def tick() -> None:
            began = time.perf_counter()
            while not done.wait(TICK):
                bar.update(min(total - 1, int(time.perf_counter() - began)) - bar.n)

        ticker = threading.Thread(target=tick, name="deik-compile-bar", daemon=True)
        ticker.start()
        try:
            yield
        finally:
            done.set()
            ticker.join()
        bar.update(total - bar.n)


def _compile(jobs: list[KernelJob]) -> dict[str, float]:
    """Compile (or load) each job's entry point in this process; {label: compile seconds} of
    those compiled."""
    from deik.backends.targets import cpu_entry

    seconds = {}
    for job in jobs:
        entry = cpu_entry(job.kernel, job.build)
        entry.compile(job.signature)
        took = entry.compile_seconds().get(tuple(job.signature))
        if took is not None:
            seconds[job.label] = took
    return seconds


def _start_worker(jobs: list[KernelJob]) -> subprocess.Popen:
    """A worker process compiling `jobs` (stderr kept in a file: a chatty compile cannot stall it)."""
    worker = subprocess.Popen(
        [sys.executable, "-m", "deik.backends.compiling"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=tempfile.TemporaryFile(),
    )
    worker.stdin.write(pickle.dumps(jobs))
    worker.stdin.close()
    return worker


def _finish(worker: subprocess.Popen) -> dict[str, float]:
    """The seconds a worker reports once done ({} if it failed: this process compiles instead)."""
    out = worker.stdout.read()
    if worker.wait() != 0 or not out.strip():
        return {}
    return json.loads(out.decode().strip().splitlines()[-1])


def missing(jobs: list[KernelJob]) -> list[KernelJob]:
    """The jobs whose entry point is neither loaded in this process nor cached on disk."""
    from deik.backends.targets import cpu_entry

    return [job for job in jobs if tuple(job.signature) not in cpu_entry(job.kernel, job.build).ready_signatures()]


def compile_all(jobs: list[KernelJob], show: bool | None = None) -> dict[str, float]:
    """Load every job's entry point into this process, compiling those missing first: side by
    side in worker processes when there is a disk cache to pass them through and more than one,
    with a bar (`show`: console.progress_bar's flag); {label: compile seconds} of each compiled."""
    from deik.backends.targets import cpu_entry

    to_compile = missing(jobs)
    if not to_compile:
        return _compile(jobs)
    seconds = {}
    names = ", ".join(job.label for job in to_compile)
    with time_bar(f"compiling {names}", expected_seconds(to_compile), show):
        cached = all(_writable(cpu_entry(job.kernel, job.build).cache_folder) for job in to_compile)
        if cached and len(to_compile) > 1 and workers() > 1:
            started = [_start_worker(share) for share in shares(to_compile, workers())]
            try:
                for worker in started:
                    seconds.update(_finish(worker))
            finally:
                for worker in started:
                    if worker.poll() is None:
                        worker.kill()
        seconds.update(_compile(jobs))  # loads what the workers compiled, compiles what they did not
    return seconds


def _writable(folder: str | None) -> bool:
    """Whether kernels compiled in another process reach this one through `folder`."""
    if folder is None:
        return False
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError:
        return False
    return os.access(folder, os.W_OK)


def main() -> None:
    """A worker: compile the pickled jobs on stdin into the disk cache; print their seconds."""
    jobs = pickle.loads(sys.stdin.buffer.read())
    print(json.dumps(_compile(jobs)))


if __name__ == "__main__":
    main()
