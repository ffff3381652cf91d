"""Run one peer adapter on a targets file; meant for the peers venv (deik is not needed).

    .venv-peers/bin/python -m benchmarks.peers.run_peer NAME targets.npz out.json   # all targets
    .venv-peers/bin/python -m benchmarks.peers.run_peer NAME targets.npz --serve    # chunk by chunk

from the repository root (`python benchmarks/peers/run_peer.py ...` works too). NAME is an
adapter module `benchmarks/peers/NAME_peer.py`; the targets file is
benchmarks.robot_targets.save_targets' .npz. Every target is solved through
common.solve_with_restarts (5 ms budget, restart poses seeded by the target's index) unless the
adapter restarts by itself (RESTARTS = False). The result: the joint solutions (N, D) in deik's
DOF order, the wall time (s) of each target's solve alone, the attempts per target, the setup
time, the library version and settings, and a frame check (the adapter's FK at three q_true
against the targets, m and rad) that catches a wrong joint map or frame.

--serve (benchmarks.peer_process drives it): set up once, write one JSON line (the result without
the solutions), then answer each stdin line {"start": i, "stop": j} with one JSON line holding
angles, seconds and attempts of targets i..j-1, until stdin closes. The protocol uses a copy of
stdout; the process's own stdout goes to stderr so that library prints cannot break it.
Failures are a JSON {"error": ...} (in out.json, or as the line) and exit status 1.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run by file path: make the `benchmarks` package importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.peers.chain_urdf import cut_urdf
from benchmarks.peers.common import BUDGET_S, RESTART_SEED, rotation_angle, solve_with_restarts

PEERS = ("ikpy", "pk", "placo", "pink", "mink", "pybullet", "rtb", "tracik", "deik")  # deik: --before (robots.py)


def frame_check(peer, targets: dict, count: int = 3) -> dict:
    """Largest gap between the adapter's FK at q_true and the targets, over `count` targets."""
    gaps = []
    for k in range(min(count, len(targets["q_true"]))):
        p, R = peer.fk(targets["q_true"][k])
        gaps.append((np.linalg.norm(p - targets["positions"][k]), rotation_angle(targets["rotations"][k], R)))
    pos, rot = np.max(gaps, axis=0)
    return {"position_m": float(pos), "rotation_rad": float(rot)}


class Runner:
    """A loaded, checked and warmed-up adapter that solves ranges of the targets."""

    def __init__(self, name: str, targets: dict, workdir: Path):
        if name not in PEERS:
            raise ValueError(f"unknown peer {name!r}; choose from {PEERS}")
        urdf = str(workdir / "chain.urdf")
        joints = cut_urdf(targets["urdf"], targets["base"], targets["tip"], urdf)
        dof_names = [str(n) for n in targets["dof_names"]]
        if joints != dof_names:
            raise ValueError(f"the cut URDF moves {joints}, deik's DOFs are {dof_names}")
        module = importlib.import_module(f"benchmarks.peers.{name}_peer")
        self.targets, self.restarts = targets, getattr(module, "RESTARTS", True)
        t0 = time.perf_counter()
        self.peer = module.Peer(urdf, targets["base"], targets["tip"], dof_names)
        setup = time.perf_counter() - t0
        restarts = f"uniform in limits, default_rng([{RESTART_SEED}, target index]), {BUDGET_S} s per target"
        self.info = {
            "name": name,
            "package": module.PACKAGE,
            "version": importlib.metadata.version(module.PACKAGE),
            "settings": {**self.peer.settings, "restarts": restarts if self.restarts else "the library's own"},
            "setup_s": setup,
            "frame_check": frame_check(self.peer, targets),
        }
        self.solve(0, 1)  # warm-up, not reported

    def _one(self, k: int) -> tuple[np.ndarray, int]:
        p, R, start = self.targets["positions"][k], self.targets["rotations"][k], self.targets["start"]
        if not self.restarts:
            return self.peer.solve(p, R, start), 1
        return solve_with_restarts(
            lambda q0, left: self.peer.solve(p, R, q0, left),
            self.peer.fk,
            p,
            R,
            np.asarray(start, dtype=float),
            self.targets["lower"],
            self.targets["upper"],
            seed=[RESTART_SEED, k],
        )

    def solve(self, start: int, stop: int) -> dict:
        """Targets start..stop-1, each timed alone: angles (n, D), seconds (n,), attempts (n,)."""
        angles, seconds, attempts = [], [], []
        for k in range(start, stop):
            t0 = time.perf_counter()
            q, made = self._one(k)
            seconds.append(time.perf_counter() - t0)
            angles.append(np.asarray(q, dtype=float).tolist())
            attempts.append(int(made))
        return {"angles": angles, "seconds": seconds, "attempts": attempts}


def load(path) -> dict:
    with np.load(path) as data:
        return {k: (data[k].item() if data[k].ndim == 0 else data[k]) for k in data.files}


def failure(name: str, error: Exception) -> dict:
    return {"name": name, "error": f"{type(error).__name__}: {error}", "traceback": traceback.format_exc(limit=-3)}


def serve(name: str, targets: dict) -> int:
    """The --serve loop described in the module docstring."""
    channel = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)

    def send(message: dict) -> None:
        channel.write(json.dumps(message) + "\n")
        channel.flush()

    with tempfile.TemporaryDirectory() as workdir:
        try:
            runner = Runner(name, targets, Path(workdir))
        except Exception as error:  # a peer that cannot load is a result to record
            send(failure(name, error))
            return 1
        send(runner.info)
        for line in sys.stdin:
            request = json.loads(line)
            try:
                send(runner.solve(request["start"], request["stop"]))
            except Exception as error:
                send(failure(name, error))
                return 1
    return 0


def main(argv: list[str] | None = None) -> int:
    name, targets_path, out = argv if argv is not None else sys.argv[1:]
    targets = load(targets_path)
    if out == "--serve":
        return serve(name, targets)
    try:
        with tempfile.TemporaryDirectory() as workdir:
            runner = Runner(name, targets, Path(workdir))
            result, code = {**runner.info, **runner.solve(0, len(targets["positions"]))}, 0
    except Exception as error:  # any failure of a peer is a result to record, not a crash
        result, code = failure(name, error), 1
    Path(out).write_text(json.dumps(result))
    return code


if __name__ == "__main__":
    sys.exit(main())
