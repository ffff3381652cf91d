"""Run one peer in the peers venv (deik is not needed there), from the repository root:

    .venv-peers/bin/python -m benchmarks.peers.run_peer NAME targets.npz            # an IK peer, serving chunks
    .venv-peers/bin/python -m benchmarks.peers.run_peer NAME problem.npz out.json   # a DE peer, every trial

(`python benchmarks/peers/run_peer.py ...` works too.) NAME is a key of benchmarks.peers.ik.PEERS
or benchmarks.peers.de.DE_PEERS.

An IK peer (benchmarks.peer_process drives it) loads the targets file (benchmarks.robot_targets
.save_targets), sets up, checks its frames (its FK at three q_true against the targets, m and
rad: a wrong joint map or frame shows) and warms up, writes one JSON line (name, version,
settings, setup seconds, frame check), then answers each stdin line {"start": i, "stop": j}
with one JSON line: the joint solutions (n, D) in deik's DOF order, each target's wall seconds
and attempts. Every target is solved through common.solve_with_restarts (5 ms budget, restart
poses seeded by the target's index) unless the adapter restarts by itself (RESTARTS = False).
The protocol uses a copy of stdout; the process's own stdout goes to stderr, so that library
prints cannot break it.

A DE peer ("scipy_de", "evosax") reads the problem file of benchmarks.de_peers (an exported
chain, per trial a target position, rotation and seed, whether the goal is a full pose, the
thresholds and the generation cap), runs one untimed warm-up (JAX compiles there), and writes
per trial the best angles, seconds, evaluations and generations to out.json.
Failures are a JSON {"error": ...} (as the line, or in out.json) and exit status 1.
"""

from __future__ import annotations

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

from benchmarks.peers.chain_fk import load_chain
from benchmarks.peers.chain_urdf import cut_urdf
from benchmarks.peers.common import BUDGET_S, RESTART_SEED, load_targets, rotation_angle, solve_with_restarts
from benchmarks.peers.de import DE_PEERS
from benchmarks.peers.ik import PEERS


def version(name: str, package: str) -> dict:
    """The record of peer `name`: its distribution and version."""
    return {"name": name, "package": package, "version": importlib.metadata.version(package)}


class Runner:
    """A loaded, checked and warmed-up IK adapter that solves ranges of the targets."""

    def __init__(self, name: str, targets: dict, workdir: Path):
        urdf = str(workdir / "chain.urdf")
        joints = cut_urdf(targets["urdf"], targets["base"], targets["tip"], urdf)
        dof_names = [str(n) for n in targets["dof_names"]]
        if joints != dof_names:
            raise ValueError(f"the cut URDF moves {joints}, deik's DOFs are {dof_names}")
        if name not in PEERS:
            raise ValueError(f"unknown peer {name!r}; choose from {tuple(PEERS)}")
        adapter = PEERS[name]
        self.info = version(name, adapter.PACKAGE)
        self.targets, self.restarts = targets, getattr(adapter, "RESTARTS", True)
        began = time.perf_counter()
        self.peer = adapter(urdf, targets["base"], targets["tip"], dof_names)
        restarts = f"uniform in limits, default_rng([{RESTART_SEED}, target index]), {BUDGET_S} s per target"
        gaps = []
        for k in range(min(3, len(targets["q_true"]))):
            p, R = self.peer.fk(targets["q_true"][k])
            gaps.append((np.linalg.norm(p - targets["positions"][k]), rotation_angle(targets["rotations"][k], R)))
        self.info |= {
            "settings": {**self.peer.settings, "restarts": restarts if self.restarts else "the library's own"},
            "setup_s": time.perf_counter() - began,
            "frame_check": dict(zip(("position_m", "rotation_rad"), np.max(gaps, axis=0).tolist())),
        }
        self.solve(0, 1)  # warm-up, not reported

    def _one(self, k: int) -> tuple[np.ndarray, int]:
        p, R, start = self.targets["positions"][k], self.targets["rotations"][k], self.targets["start"]
        if not self.restarts:
            return self.peer.solve(p, R, start), 1
        limits = (self.targets["lower"], self.targets["upper"])
        attempt = lambda q0, left: self.peer.solve(p, R, q0, left)  # noqa: E731
        return solve_with_restarts(attempt, self.peer.fk, (p, R), start, limits, [RESTART_SEED, k])

    def solve(self, start: int, stop: int) -> dict:
        """Targets start..stop-1, each timed alone: angles (n, D), seconds (n,), attempts (n,)."""
        out = {"angles": [], "seconds": [], "attempts": []}
        for k in range(start, stop):
            began = time.perf_counter()
            q, made = self._one(k)
            out["seconds"].append(time.perf_counter() - began)
            out["angles"].append(np.asarray(q, dtype=float).tolist())
            out["attempts"].append(int(made))
        return out


def failure(name: str, error: Exception) -> dict:
    return {"name": name, "error": f"{type(error).__name__}: {error}", "traceback": traceback.format_exc(limit=-3)}


def serve(name: str, targets_file: str) -> int:
    """The IK peer's loop described in the module docstring."""
    channel = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)

    def send(message: dict) -> None:
        channel.write(json.dumps(message) + "\n")
        channel.flush()

    targets = load_targets(targets_file)
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


def de_trials(name: str, problem_file: str) -> dict:
    """The DE peer's record of every trial of the problem file."""
    if name not in DE_PEERS:
        raise ValueError(f"unknown peer {name!r}; choose from {tuple(DE_PEERS)}")
    package, settings, make_solver = DE_PEERS[name]
    chain = load_chain(problem_file)
    solve = make_solver(chain, bool(chain["pose"]), chain["tolerances"].tolist(), int(chain["max_generations"]))
    targets = list(zip(chain["positions"], chain["rotations"], chain["seeds"].tolist()))
    solve(targets[0][0], targets[0][1], targets[0][2] + 10_000)  # warm-up, not timed
    return {**version(name, package), "settings": settings, "trials": [solve(p, R, seed) for p, R, seed in targets]}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 2:
        return serve(*argv)
    name, problem_file, out = argv
    try:
        result, code = de_trials(name, problem_file), 0
    except Exception as error:  # a failing peer is a result to record, not a crash
        result, code = failure(name, error), 1
    Path(out).write_text(json.dumps(result))
    return code


if __name__ == "__main__":
    sys.exit(main())
