"""`deik clip IN --out OUT` on the shared clips with draws of capture noise no setting was chosen on.

    PYTHONPATH=src python -m benchmarks.noise_draws [--clips walk kick ...] [--out benchmarks/results]

clip_targets judges one draw of its noisy transform per case; a rule tuned to those draws can
fail on the next. Here every shared clip but the get-up (its cleaning takes the longest), as it
is and on three other rig families (judging/cases.py: studio, digits, toes), gets judging/cases.py's
noisy transform with two more draws of its noise (0.2 degrees on every rotation channel, 1 mm on
the root, the body 12 mm under the floor; seeds 11 + i and 21 + i for the i-th rig) and one
stronger draw (0.35 degrees, seed 31 + i). Each case is cleaned and judged as clip_targets does,
against the same targets; the record counts the cases meeting each.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

from benchmarks.clip_targets import TARGETS, run_case, table
from benchmarks.data import need
from benchmarks.harness import parser, start
from judging.cases import digits, noisy, source_case, studio, toes

CLIPS = ("walk", "run", "kick", "punch", "jump", "dance_a", "crawl")
RIGS = {"base": None, "studio": studio, "digits": digits, "toes": toes}
DRAWS = ((11, 0.2), (21, 0.2), (31, 0.35))  # (seed + the rig's index, degrees)


def draws(folder: Path, clips: tuple[str, ...]):
    """The cases: each clip on each rig family with each draw of noise."""
    for clip in clips:
        base = source_case(folder / f"humanoid3d_{clip}.bvh")
        for i, (rig, transform) in enumerate(RIGS.items()):
            shaped = base if transform is None else transform(base)
            for seed, degrees in DRAWS:
                case = noisy(shaped, seed + i, degrees)
                yield dataclasses.replace(case, name=f"{clip}_{rig}_{seed + i}_{degrees}")


def main(argv=None) -> dict:
    """Clean and judge every case; write the JSON and markdown; print the table."""
    p = parser(__doc__)
    p.add_argument("--clips", nargs="+", metavar="NAME", default=list(CLIPS), help="shared clips by name")
    run = start("noise_draws", p, argv)
    folder = need("humanoid")
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for case in draws(folder, tuple(run.args.clips)):
            rows.append(run_case(case, Path(scratch)))
            print(f"{case.name}: {rows[-1]['verdicts']}", flush=True)
    for target in ("sliding", "depth", "peaks", "listed", "travel", "steps"):
        run.target(f"cases meeting {target}", len(rows), sum(r["verdicts"].get(target, False) for r in rows), "cases")
    met = sum(all(r["verdicts"].values()) for r in rows)
    run.target("cases meeting every target", len(rows), met, "cases")
    over = sum(r.get("sliding_mm_per_frame", float("inf")) > 5.0 for r in rows)
    run.target("cases sliding more than 5 mm a frame", 0, over, "cases", at_most=True)
    body = f"{met} of {len(rows)} cases meet every target\n\n" + table(rows)
    return run.finish({"goals": TARGETS, "cases": rows}, body)


if __name__ == "__main__":
    main()
