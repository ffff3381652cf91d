"""The same library job on a Ray cluster (`--executor ray [--address ADDR]`, the `deik[ray]` extra).

Each clip is one Ray task reserving `threads` CPUs, with Numba, OpenMP and BLAS limited to as
many threads, so Ray places as many clips on each node as it has cores. Without an address
(or with `local`) a Ray instance is started on this machine for the run and stopped after it;
`auto` or `ray://HOST:PORT` joins a running cluster. Workers read the inputs and write the
outputs and sidecars at the paths the driver gives: on a cluster of several machines the clip
and output folders must be on storage every node mounts, and deik installed on every node.
Frame progress comes back through a Ray queue. A task whose worker dies fails only its clip
(no retry: a rerun redoes it, as with local workers).
"""

from __future__ import annotations

import contextlib
import logging
import socket
from collections.abc import Iterator, Sequence
from types import ModuleType

from deik.errors import SolveError
from deik.library.jobs import Event, Job, Outcome, Task
from deik.library.local import THREAD_VARIABLES, attempt

RAY_MISSING = 'the Ray executor needs Ray, an optional extra: pip install "deik[ray]"'
POLL_S = 0.25  # how often the driver looks for progress while tasks run
CONNECT_S = 10.0  # how long a cluster's address may take to answer before the run is refused


def require_ray() -> ModuleType:
    """The ray module, else ImportError naming the extra to install."""
    try:
        import ray
    except ImportError:
        raise ImportError(RAY_MISSING) from None
    return ray


def _start(ray: ModuleType, address: str | None) -> None:
    """ray.init on `address` (None or "local": a Ray started here); SolveError with Ray's reason
    when it cannot (its processes too slow to start under a memory cap, nobody at the address):
    the machine's or the cluster's state, not a bug of deik."""
    here = address in (None, "local")
    if not here:
        check_address(address)
    try:
        ray.init(
            address=None if here else address,
            include_dashboard=False,
            log_to_driver=False,
            logging_level=logging.ERROR,
        )
    except Exception as error:  # noqa: BLE001 - Ray raises many kinds; each means Ray did not start
        reason = " ".join(str(error).split()[:40]) or type(error).__name__
        where = "start Ray on this machine" if here else f"join the Ray cluster at {address!r}"
        raise SolveError(
            f"the Ray executor could not {where} ({reason}); check free memory (Ray needs about 2 GiB) and the "
            "address, or run with --executor local"
        ) from None


def check_address(address: str) -> None:
    """SolveError when nothing accepts a connection at `address` (HOST:PORT or ray://HOST:PORT)
    within CONNECT_S: ray.init waits on such an address for ever. "auto" and other forms are
    left to Ray."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_S).close()
    except (OSError, ValueError, OverflowError) as error:
        reason = getattr(error, "strerror", None) or error
        raise SolveError(
            f"--address {address}: nothing answers there within {CONNECT_S:g} s ({reason}); "
            "check that the Ray cluster runs at that address, or run with --executor local"
        ) from None


def _run_on_worker(task, job, queue) -> tuple:
    """What a Ray task does: attempt the job, sending frame progress through `queue`."""

    def progress(done: int, total: int) -> None:
        with contextlib.suppress(Exception):  # progress is a courtesy: never fail a clip over it
            queue.put_nowait((job.name, done, total))

    return attempt(task, job, progress)


def ray_events(
    jobs: Sequence[Job], task: Task, address: str | None, in_flight: int | None, threads: int = 1
) -> Iterator[Event]:
    """Run `jobs` as Ray tasks (at most `in_flight` at once, None: all) of `threads` CPUs each
    on the cluster at `address` (None or "local": a Ray started here for the run); yield
    ("started", job), ("progress", job, done, total) and ("finished", Outcome) events."""
    ray = require_ray()
    from ray.util.queue import Empty, Queue

    ours = not ray.is_initialized()
    if ours:
        _start(ray, address)
    queue = Queue(actor_options={"num_cpus": 0})
    remote = ray.remote(_run_on_worker).options(
        num_cpus=threads, max_retries=0, runtime_env={"env_vars": {key: str(threads) for key in THREAD_VARIABLES}}
    )
    waiting, running = list(jobs)[::-1], {}
    by_name = {job.name: job for job in jobs}
    try:
        while waiting or running:
            while waiting and len(running) < (in_flight or len(jobs)):
                job = waiting.pop()
                running[remote.remote(task, job, queue)] = job
                yield ("started", job)
            ready, _ = ray.wait(list(running), num_returns=1, timeout=POLL_S)
            with contextlib.suppress(Empty):
                for name, done, total in queue.get_nowait_batch(queue.qsize()):
                    yield ("progress", by_name[name], done, total)
            for reference in ready:
                job = running.pop(reference)
                try:
                    status, value, seconds = ray.get(reference)
                except ray.exceptions.RayError as error:  # the worker died, or could not load the task
                    last = [line for line in str(error).splitlines() if line.strip()][-1:] or [type(error).__name__]
                    reason = f"its Ray worker failed: {last[0].strip()}; rerun to redo it"
                    yield ("finished", Outcome(job, "failed", reason=reason))
                    continue
                outcome = Outcome(job, status, seconds, *((value, "") if status == "done" else (None, value)))
                yield ("finished", outcome)
    finally:
        for reference in running:
            with contextlib.suppress(Exception):
                ray.cancel(reference, force=True)
        with contextlib.suppress(Exception):
            queue.shutdown()
        if ours:
            ray.shutdown()
