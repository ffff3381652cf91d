"""A peer IK library as a long-lived subprocess in .venv-peers, fed chunks of targets through pipes.

The process (benchmarks.peers.run_peer) is started once per case and loads, checks and
warms up its library before the first chunk, so none of that is in the timed turns. Each request
is one JSON line with a target range; each answer one JSON line with the solutions, the wall time
of every target (s) and the attempts made. stderr goes to a file, so a chatty library cannot
fill a pipe and stall.
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import tempfile
from pathlib import Path

from benchmarks.harness import Dropped

ROOT = Path(__file__).resolve().parents[1]
PEERS_PYTHON = ROOT / ".venv-peers" / "bin" / "python"
SETUP_TIMEOUT_S = 300  # loading a library (torch, jax) on a loaded machine
CHUNK_TIMEOUT_S = 900  # one chunk of targets; ikpy and pytorch-kinematics have no budget


class PeerFailed(Dropped):
    """The peer could not start, answered with an error, died or timed out: it drops out of the
    remaining turns (harness.take_turns)."""


class PeerProcess:
    """One peer adapter serving chunks: PeerProcess(name, targets.npz); .info (version, settings,
    setup_s, frame_check) once ready(); .solve(start, stop) -> dict of lists; .close()."""

    def __init__(self, name: str, targets_file: Path):
        if not PEERS_PYTHON.exists():
            raise PeerFailed(f"{PEERS_PYTHON} is missing (make bench-peers creates it)")
        self.name, self.info = name, None
        self.log = tempfile.TemporaryFile(mode="w+")
        self.proc = subprocess.Popen(
            [str(PEERS_PYTHON), "-m", "benchmarks.peers.run_peer", name, str(targets_file)],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )

    def _receive(self, timeout: float) -> dict:
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else None
        if not line:
            self.close()
            reason = f"no answer within {timeout} s" if line is None else f"exit {self.proc.returncode}"
            self.log.seek(0)
            raise PeerFailed(f"{reason}: {self.log.read().strip()[-800:]}")
        message = json.loads(line)
        if "error" in message:
            self.close()
            raise PeerFailed(message["error"])
        return message

    def ready(self) -> dict:
        """Wait for the set-up, frame check and warm-up; returns the peer's description."""
        if self.info is None:
            self.info = self._receive(SETUP_TIMEOUT_S)
        return self.info

    def solve(self, start: int, stop: int) -> dict:
        """Targets start..stop-1: {"angles": (n, D), "seconds": (n,), "attempts": (n,)} as lists."""
        self.ready()
        try:
            self.proc.stdin.write(json.dumps({"start": start, "stop": stop}) + "\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass  # the process died; _receive reports it with its log
        return self._receive(CHUNK_TIMEOUT_S)

    def close(self) -> None:
        """Close stdin (the process exits) and wait; kill it if it does not."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
                self.proc.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
