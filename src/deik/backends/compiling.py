"""Compiling the CPU kernels a command needs side by side, in worker processes, with a bar that
moves from the first second.

Numba compiles a kernel in one thread, and holds one lock while it does, so two kernels in one
process compile one after the other. A first float32 solve needs two (its DE kernel and the
float64 report), `deik warmup` four: each worker process compiles its share (the longest first,
to the least loaded worker) into the disk cache and reports each kernel's compile seconds, and
this process then loads them, as a later command would. A DE kernel, most of the wait, is itself
split when there are workers to spare: another worker compiles its generations loop's call tree
beside it (PartJob, deik.backends.sharing). Meanwhile a bar runs over the expected seconds.
Without a writable disk cache, or when a worker fails, this process compiles what is left itself.

    python -m deik.backends.compiling   (a worker: reads pickled (folder, jobs) on stdin, prints its report as JSON)
"""

from __future__ import annotations

import json
import logging
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
# A DE kernel compiled while another worker compiles its generations loop (PartJob) takes SPLIT of
# its time alone, slowed by SIDE_BY_SIDE while the helper runs, and the helper spends HELPER of it
# on the loop: two runs of benchmarks/cold_start.py on an idle 2-core AMD EPYC VM, the float32 DE
# kernel for position goals 11.4-12.0 s of Numba's timer against 14.5-14.7 s alone, its loop
# 6.8 s (docs/performance.md)
SPLIT = 0.61
HELPER = 0.41
# the linked function of a kernel that a helper compiles, and the types of the kernel's locals
# its call passes (names of numba.core.types)
PARTS = {"launch": ("run_generations", (("lazy", "boolean"),))}


class KernelJob(NamedTuple):
    """One entry point to compile: kernel (a function of deik.backends.cpu_kernels), the build's
    switches, the signature (a tuple of Numba types), its name in notes, and its expected seconds."""

    kernel: str
    build: frozenset
    signature: tuple
    label: str
    seconds: float


class PartJob(NamedTuple):
    """The call tree of `function` (PARTS) in `job`'s kernel, compiled beside the kernel."""

    job: KernelJob
    function: str

    @property
    def label(self) -> str:
        """Its name in reports, e.g. "DE float32 [position]: run_generations"."""
        return f"{self.job.label}: {self.function}"


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


def shares(jobs: list[KernelJob], workers: int) -> list[list[KernelJob | PartJob]]:
    """Jobs split among up to `workers` workers (_loads)."""
    return [share for _, share in _loads(jobs, workers)]


def _loads(jobs: list[KernelJob], workers: int) -> list[tuple[float, list[KernelJob | PartJob]]]:
    """(expected seconds, jobs) of each worker that gets any. When there are at least two workers
    per DE kernel (a "launch" job), each has a worker of its own, at SPLIT of its seconds, and a
    helper that compiles its PartJob first; the other jobs go the longest first, each to the least
    loaded worker."""
    launches = [job for job in jobs if job.kernel in PARTS]
    split = bool(launches) and workers >= 2 * len(launches)
    loads = []
    for job in launches if split else []:
        loads += [[job.seconds * SPLIT, [job]], [job.seconds * HELPER, [PartJob(job, PARTS[job.kernel][0])]]]
    rest = [job for job in jobs if not (split and job.kernel in PARTS)]
    loads += [[0.0, []] for _ in range(max(1 - len(loads), min(workers - len(loads), len(rest))))]
    for job in sorted(rest, key=lambda j: -j.seconds):
        least = min(loads, key=lambda load: load[0])
        least[0] += job.seconds
        least[1].append(job)
    return [(seconds, share) for seconds, share in loads if share]


def expected_seconds(jobs: list[KernelJob]) -> float:
    """About how long compile_all takes: its busiest worker's share, slowed by SIDE_BY_SIDE for as
    long as another worker compiles beside it; workers beyond the cores count as none (they take
    turns on them)."""
    n = min(workers(), cores())
    totals = sorted((seconds for seconds, _ in _loads(jobs, n if n > 1 else 1)), reverse=True)
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


def _compile(jobs: list[KernelJob | PartJob]) -> dict[str, float]:
    """Compile (or load) each job's entry point in this process, and each PartJob's call tree;
    {label: compile seconds} of the entry points compiled and of the PartJobs."""
    from deik.backends.targets import cpu_entry

    seconds = {}
    for job in jobs:
        if isinstance(job, PartJob):
            began = time.perf_counter()
            _compile_part(job)
            seconds[job.label] = time.perf_counter() - began
            continue
        entry = cpu_entry(job.kernel, job.build)
        entry.compile(job.signature)
        took = entry.compile_seconds().get(tuple(job.signature))
        if took is not None:
            seconds[job.label] = took
    return seconds


def _compile_part(part: PartJob) -> None:
    """Compile a PartJob's function for the types its kernel's compile will ask for."""
    from numba.core import types

    from deik.backends import cpu_kernels
    from deik.backends.sharing import call_signature
    from deik.backends.targets import cpu_build

    function, local_types = PARTS[part.job.kernel]
    local_types = {name: getattr(types, kind) for name, kind in local_types}
    signature = call_signature(getattr(cpu_kernels, part.job.kernel), function, part.job.signature, local_types)
    getattr(cpu_build(part.job.build), function).compile(signature)


def _start_worker(jobs: list[KernelJob | PartJob], folder: str) -> subprocess.Popen:
    """A worker process compiling `jobs`, sharing linked functions through `folder` (stderr kept
    in a file: a chatty compile cannot stall it)."""
    worker = subprocess.Popen(
        [sys.executable, "-m", "deik.backends.compiling"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=tempfile.TemporaryFile(),
    )
    worker.stdin.write(pickle.dumps((folder, jobs)))
    worker.stdin.close()
    return worker


def _finish(worker: subprocess.Popen) -> dict:
    """What a worker reports once done: {"seconds": {label: compile seconds}, "loaded": [names of
    the linked functions it loaded from another worker]} ({} if it failed: this process compiles
    instead)."""
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
        folders = [cpu_entry(job.kernel, job.build).cache_folder for job in to_compile]
        split = shares(to_compile, workers())
        if all(map(_writable, folders)) and len(split) > 1:
            seconds.update(_in_workers(split, folders[0]))
        seconds.update(_compile(jobs))  # loads what the workers compiled, compiles what they did not
    return seconds


def _in_workers(split: list[list[KernelJob | PartJob]], cache: str) -> dict[str, float]:
    """Run one worker per share of `split`, sharing linked functions through a folder of their
    own in the disk cache's folder `cache` (writable, as the workers need it anyway); {label:
    compile seconds}, a kernel compiled beside its PartJob counted as alone."""
    seconds, log = {}, logging.getLogger(__name__)
    with tempfile.TemporaryDirectory(prefix="deik-compile-", dir=cache) as folder:
        started = [_start_worker(share, folder) for share in split]
        try:
            for worker in started:
                report = _finish(worker)
                seconds.update(report.get("seconds", {}))
                log.debug("a compile worker reported %s", json.dumps(report))
        finally:
            for worker in started:
                if worker.poll() is None:
                    worker.kill()
    parts = {job.label: job.job.label for share in split for job in share if isinstance(job, PartJob)}
    helped, share = set(parts.values()), SPLIT + (SIDE_BY_SIDE - 1.0) * HELPER
    return {label: s / share if label in helped else s for label, s in seconds.items() if label not in parts}


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
    """A worker: compile the pickled (folder, jobs) on stdin into the disk cache, sharing linked
    functions through the folder; print _finish's report."""
    from deik.backends import compiling, sharing  # this module by its name, as the jobs were pickled

    folder, jobs = pickle.loads(sys.stdin.buffer.read())
    with sharing.through(folder):
        seconds = compiling._compile(jobs)
    print(json.dumps({"seconds": seconds, "loaded": sharing.loaded}))


if __name__ == "__main__":
    main()
