"""Run one DE peer on a DE problem file; meant for the peers venv (deik is not needed).

    .venv-peers/bin/python -m benchmarks.peers.run_de_peer NAME problem.npz out.json

from the repository root (`python benchmarks/peers/run_de_peer.py ...` works too). NAME:
"scipy_de" or "evosax" (modules NAME_peer.py). The problem
file (written by benchmarks.de_peers) holds an exported chain plus, per trial, a target
position (T, 3) and rotation (T, 3, 3) and a seed (T,), whether the goal is a full pose, the
thresholds (m, rad) and the generation cap. One untimed warm-up run comes first (JAX
compiles there). Writes JSON: per trial the best angles (D,), seconds, evaluations and
generations; on failure {"error": ...} and exit 1.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import sys
import traceback
from pathlib import Path

if __package__ in (None, ""):  # run by file path: make the `benchmarks` package importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.peers.chain_fk import load_chain

DE_PEERS = ("scipy_de", "evosax")


def run(name: str, problem_file: str) -> dict:
    if name not in DE_PEERS:
        raise ValueError(f"unknown DE peer {name!r}; choose from {DE_PEERS}")
    module = importlib.import_module(f"benchmarks.peers.{name}_peer")
    chain = load_chain(problem_file)
    solve = module.make_solver(chain, bool(chain["pose"]), chain["tolerances"].tolist(), int(chain["max_generations"]))
    targets = list(zip(chain["positions"], chain["rotations"], chain["seeds"].tolist()))
    solve(targets[0][0], targets[0][1], targets[0][2] + 10_000)  # warm-up, not timed
    return {
        "name": name,
        "package": module.PACKAGE,
        "version": importlib.metadata.version(module.PACKAGE),
        "settings": module.SETTINGS,
        "trials": [solve(p, R, seed) for p, R, seed in targets],
    }


def main(argv: list[str] | None = None) -> int:
    name, problem_file, out = argv if argv is not None else sys.argv[1:]
    try:
        result, code = run(name, problem_file), 0
    except Exception as error:  # a failing peer is a result to record
        result, code = (
            {"name": name, "error": f"{type(error).__name__}: {error}", "traceback": traceback.format_exc(limit=-3)},
            1,
        )
    Path(out).write_text(json.dumps(result))
    return code


if __name__ == "__main__":
    sys.exit(main())
