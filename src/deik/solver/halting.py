"""Stopping a kernel launch from outside: the time limit and Ctrl-C, within a fraction of a second.

A launch is one compiled call that releases the GIL; Python's own Ctrl-C handler runs only when
it returns, and one LM iteration of a 900-DOF skeleton takes a second (the polish grows as DOFs
cubed). So the kernels read a stop flag, Status.halt (1,), before every LM iteration, every
Cholesky column and every generation (deik.device.lm, deik.backends.cpu_kernels), and one
daemon thread here sets it: at the launch's deadline, or as soon as Ctrl-C (SIGINT) arrives. Signals
reach it through Python's wakeup file descriptor (signal.set_wakeup_fd), which the interpreter's
C-level handler writes to at once even while the main thread is inside a kernel; Python's own
handler then raises KeyboardInterrupt when the launch returns, as it would have. A wakeup
descriptor set by someone else (an asyncio loop) is restored afterwards and told of the signal.

`guarded(halt, deadline)` arms it around one launch; launches too short to overrun (below
GUARD_SECONDS by the solve's estimate) skip it: arming costs a few microseconds.
"""

from __future__ import annotations

import math
import os
import select
import signal
import socket
import threading
import time

import numpy as np

GUARD_SECONDS = 0.05  # launches expected to take longer than this are guarded


class _Watchdog:
    """The one thread that sets a launch's halt flag at its deadline or on a signal."""

    def __init__(self):
        self._signals, self._signal_writer = socket.socketpair()
        self._wake, self._wake_writer = socket.socketpair()
        for end in (self._signals, self._signal_writer, self._wake, self._wake_writer):
            end.setblocking(False)
        self._lock = threading.Lock()
        self._halt, self._deadline, self._forward = None, math.inf, -1
        threading.Thread(target=self._watch, name="deik-halt", daemon=True).start()

    @property
    def signal_fd(self) -> int:
        return self._signal_writer.fileno()

    def arm(self, halt: np.ndarray, deadline: float, forward: int) -> None:
        """Set halt[0] at `deadline` (time.perf_counter) or on a signal until disarm; a signal
        byte is also written to `forward` (a wakeup fd set before ours; -1: none)."""
        with self._lock:
            self._halt, self._deadline, self._forward = halt, deadline, forward
        if not math.isinf(deadline):  # without a deadline the thread sleeps until a signal comes
            self._poke()

    def disarm(self) -> None:
        with self._lock:
            self._halt, self._deadline, self._forward = None, math.inf, -1

    def _poke(self) -> None:
        try:
            self._wake_writer.send(b"\0")
        except BlockingIOError:  # a wake-up is pending already
            pass

    def _watch(self) -> None:
        while True:
            with self._lock:
                deadline = self._deadline
            timeout = None if math.isinf(deadline) else max(0.0, deadline - time.perf_counter())
            ready, _, _ = select.select([self._signals, self._wake], [], [], timeout)
            signalled = self._drain(self._signals) if self._signals in ready else b""
            if self._wake in ready:
                self._drain(self._wake)
            with self._lock:
                interrupted = signal.SIGINT in signalled  # other signals with Python handlers pass by
                if self._halt is not None and (interrupted or time.perf_counter() >= self._deadline):
                    self._halt[0] = 1
                    self._deadline = math.inf
                if signalled and self._forward >= 0:
                    try:
                        os.write(self._forward, signalled)
                    except OSError:
                        pass

    @staticmethod
    def _drain(end: socket.socket) -> bytes:
        data = b""
        try:
            while chunk := end.recv(256):
                data += chunk
        except BlockingIOError:
            pass
        return data


_watchdog: _Watchdog | None = None
_watchdog_lock = threading.Lock()


def _the_watchdog() -> _Watchdog:
    global _watchdog
    if _watchdog is None:  # the lock only until it exists: every guarded launch asks
        with _watchdog_lock:
            if _watchdog is None:
                _watchdog = _Watchdog()
    return _watchdog


class guarded:  # noqa: N801 (a context manager used like a function, as contextlib's are)
    """Around one launch: halt[0] is set at `deadline` (time.perf_counter; inf: none) or when a
    signal arrives (only from the main thread, the one Python delivers signals to). A launch
    expected to take less than GUARD_SECONDS and with no deadline inside that runs unguarded.
    (A class rather than a generator: contextlib's machinery cost 1.5 us of a 0.1 ms solve.)"""

    __slots__ = ("_halt", "_deadline", "_armed", "_main", "_previous")

    def __init__(self, halt: np.ndarray, deadline: float, expected_seconds: float):
        halt[0] = 0
        self._halt, self._deadline = halt, deadline
        self._armed = not (
            expected_seconds < GUARD_SECONDS and deadline - time.perf_counter() > expected_seconds + GUARD_SECONDS
        )

    def __enter__(self) -> None:
        if self._armed:
            watchdog = _the_watchdog()
            self._main = threading.current_thread() is threading.main_thread()
            self._previous = signal.set_wakeup_fd(watchdog.signal_fd, warn_on_full_buffer=False) if self._main else -1
            watchdog.arm(self._halt, self._deadline, self._previous)

    def __exit__(self, *exc_info) -> None:
        if self._armed:
            _the_watchdog().disarm()
            if self._main:
                signal.set_wakeup_fd(self._previous)
