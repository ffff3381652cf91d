"""Run one peer adapter on a targets file; meant for the peers venv (deik is not needed).

    .venv-peers/bin/python -m benchmarks.peers.run_peer NAME targets.npz out.json

from the repository root (`python benchmarks/peers/run_peer.py ...` works too). NAME is an
adapter module `benchmarks/peers/NAME_peer.py`. The targets file is
benchmarks.robot_targets.save_targets' .npz. Writes JSON: the joint solutions
(N, D) in deik's DOF order, the wall time (s) of each solve call alone, the setup time, the
library version and settings, and a frame check (the adapter's FK at three q_true against the
targets, m and rad) that catches a wrong joint map or frame. On failure writes {"error": ...}
and exits 1.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run by file path: make the `benchmarks` package importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.peers.chain_urdf import cut_urdf
from benchmarks.peers.common import rotation_angle

PEERS = ("ikpy", "pk", "placo", "pink", "mink", "pybullet")


def frame_check(peer, targets: dict, count: int = 3) -> dict:
    """Largest gap between the adapter's FK at q_true and the targets, over `count` targets."""
    gaps = []
    for k in range(min(count, len(targets["q_true"]))):
        p, R = peer.fk(targets["q_true"][k])
        gaps.append((np.linalg.norm(p - targets["positions"][k]), rotation_angle(targets["rotations"][k], R)))
    pos, rot = np.max(gaps, axis=0)
    return {"position_m": float(pos), "rotation_rad": float(rot)}


def run(name: str, targets: dict, workdir: Path) -> dict:
    """Load, check and time the adapter `name` on every target."""
    urdf = str(workdir / "chain.urdf")
    joints = cut_urdf(targets["urdf"], targets["base"], targets["tip"], urdf)
    dof_names = [str(n) for n in targets["dof_names"]]
    if joints != dof_names:
        raise ValueError(f"the cut URDF moves {joints}, deik's DOFs are {dof_names}")
    module = importlib.import_module(f"benchmarks.peers.{name}_peer")
    t0 = time.perf_counter()
    peer = module.Peer(urdf, targets["base"], targets["tip"], dof_names)
    setup = time.perf_counter() - t0
    check = frame_check(peer, targets)
    start = np.asarray(targets["start"], dtype=float)
    peer.solve(targets["positions"][0], targets["rotations"][0], start)  # warm-up, not timed
    angles, seconds = [], []
    for p, R in zip(targets["positions"], targets["rotations"]):
        t0 = time.perf_counter()
        q = peer.solve(p, R, start)
        seconds.append(time.perf_counter() - t0)
        angles.append(np.asarray(q, dtype=float))
    return {
        "name": name,
        "package": module.PACKAGE,
        "version": importlib.metadata.version(module.PACKAGE),
        "settings": peer.settings,
        "setup_s": setup,
        "frame_check": check,
        "angles": np.array(angles).tolist(),
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    name, targets_path, out = argv if argv is not None else sys.argv[1:]
    with np.load(targets_path) as data:
        targets = {k: (data[k].item() if data[k].ndim == 0 else data[k]) for k in data.files}
    try:
        if name not in PEERS:
            raise ValueError(f"unknown peer {name!r}; choose from {PEERS}")
        with tempfile.TemporaryDirectory() as workdir:
            result, code = run(name, targets, Path(workdir)), 0
    except Exception as error:  # any failure of a peer is a result to record, not a crash
        result = {
            "name": name,
            "error": f"{type(error).__name__}: {error}",
            "traceback": traceback.format_exc(limit=-3),
        }
        code = 1
    Path(out).write_text(json.dumps(result))
    return code


if __name__ == "__main__":
    sys.exit(main())
