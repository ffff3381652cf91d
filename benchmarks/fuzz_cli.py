"""Fuzz the command line with mutated input files: every case must end in a result or one line
`deik: error: FILE...` (exit 2), never a traceback, an internal error, a hang or a crash.

Seeds: a small BVH clip, a small URDF arm and a TOML problem (benchmarks/fuzz_seeds/), plus the
BVH and URDF files of the shared data when present, and the tables read beside them
(benchmarks/fuzz_inputs.py: segments, limits, tracks, a map, a library record), read by their
readers; one case in NAMED_EVERY is a problem file naming its own output. Each case mutates
one seed (a flipped byte, a deleted, doubled or truncated line, scale extremes, a number
swapped for NaN, 1e308, 1e300, 1_000, 0x10, 5,000 digits or nothing, CR-only line endings,
deep nesting) and runs `deik info` (BVH, URDF) or `deik solve --problem` (TOML) in this
process, with an alarm as the time bound and an address-space limit as the memory bound.
The same seed gives the same cases.

    python -m benchmarks.fuzz_cli --cases 3000     # results/fuzz_cli.{json,md,png}
"""

from __future__ import annotations

import contextlib
import functools
import io
import random
import re
import resource
import signal
import sys
import tempfile
import time
from pathlib import Path

from benchmarks import harness
from benchmarks.data import shared_data
from benchmarks.fuzz_inputs import HUGE, named_input_case, read_table, scaled, table_seeds
from deik.cli import main as deik_main
from deik.io.bvh import parse_bvh

SEEDS = Path(__file__).resolve().parent / "fuzz_seeds"
CASE_SECONDS = 30  # a case running longer counts as a hang
NAMED_EVERY = 25  # one case in this many is a problem file that names its own output


NASTY = [
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "1_000",
    "0x10",
    "",
    "-0",
    "99999999999999999999",
    "1e5e5",
    "e5",
    "true",
    "[]",
    '"x"',
    "{",
    "}",
    "-",
    ".",
]
NASTY += HUGE  # 1e300, numbers of 401 and 5,000 digits, -1e-3 (a negative number, not an option)
NUMBER = re.compile(r"-?\d+(\.\d+)?(e-?\d+)?")


def seeds() -> list[tuple[str, str, bytes]]:
    """(name, kind, content) of every seed file: our own, the tables (kind "table"), then the
    shared BVH and URDFs."""
    shared = shared_data()
    paths = [SEEDS / f"seed.{kind}" for kind in ("bvh", "urdf", "toml")]
    paths += sorted(shared.glob("humanoid/*.bvh"))[:3] + sorted(shared.glob("robots/*.urdf"))
    ours = [(path.name, path.suffix[1:], path.read_bytes()) for path in paths]
    return ours[:3] + table_seeds() + ours[3:]


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One to three random mutations of `data`."""
    for _ in range(rng.randint(1, 3)):
        lines = data.split(b"\n")
        choice = rng.randrange(9)
        if choice == 8:
            data = scaled(data, rng)
            continue
        k = rng.randrange(len(lines))
        if choice == 0 and data:
            i = rng.randrange(len(data))
            data = data[:i] + bytes([rng.randrange(256)]) + data[i + 1 :]
        elif choice == 1:
            del lines[k]
            data = b"\n".join(lines)
        elif choice == 2:
            lines.insert(k, lines[k])
            data = b"\n".join(lines)
        elif choice == 3:
            data = data[: rng.randrange(len(data) + 1)]
        elif choice == 4:
            text = lines[k].decode("latin-1")
            numbers = list(NUMBER.finditer(text))
            if numbers:
                m = rng.choice(numbers)
                text = text[: m.start()] + rng.choice(NASTY) + text[m.end() :]
            lines[k] = text.encode("latin-1")
            data = b"\n".join(lines)
        elif choice == 5:
            data = data.replace(b"\n", b"\r")
        elif choice == 6:
            depth = rng.choice([10, 1000, 100_000])
            lines.insert(k, b"x = " + b"[" * depth + b"]" * depth if rng.random() < 0.5 else b"{" * depth)
            data = b"\n".join(lines)
        else:
            words = lines[k].split(b" ")
            if len(words) > 1:
                words.insert(rng.randrange(len(words)), rng.choice(NASTY).encode())
            lines[k] = b" ".join(words)
            data = b"\n".join(lines)
    return data


class Hang(Exception):
    """A case ran past CASE_SECONDS."""


def _alarm(signum, frame):
    raise Hang()


def bounded(call):
    """(call's value or Hang, seconds) with CASE_SECONDS as the bound."""
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_SECONDS)
    began = time.perf_counter()
    try:
        value = call()
    except Hang as hang:
        value = hang
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return value, time.perf_counter() - began


def run_case(path: Path, kind: str) -> tuple[int, str, float]:
    """(exit status, stderr, seconds) of the CLI on `path`; status -1 for a hang."""
    argv = ["solve", "--problem", str(path)] if kind == "toml" else ["info", str(path)]
    err, out = io.StringIO(), io.StringIO()

    def call():
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            return deik_main(argv)

    status, seconds = bounded(call)
    return (-1 if isinstance(status, Hang) else status), err.getvalue(), seconds


def problem_with(status: int, err: str, path: Path) -> str | None:
    """Why a case's outcome breaks the rules, or None when it is fine."""
    if status == -1:
        return f"ran past {CASE_SECONDS} s"
    if status == 0:
        return None
    if status != 2:
        return f"exit status {status}: {err.strip()[:300]}"
    if err.count("\n") != 1 or not err.startswith("deik: error: "):
        return f"not one 'deik: error:' line: {err[:300]!r}"
    if path.name not in err:
        return f"the message does not name the file: {err.strip()[:300]}"
    return None


def fuzz(cases: int, seed: int, folder: Path) -> dict:
    """Run `cases` mutated cases (round robin over the seeds); returns counts, times and failures."""
    rng = random.Random(seed)
    pool = seeds()
    clip = (SEEDS / "seed.bvh").read_bytes()
    skeleton = parse_bvh(clip, "seed.bvh").skeleton
    outcomes = {"ok": 0, "error": 0}
    failures, slowest = [], 0.0
    for n in range(cases):
        name, kind, data = pool[n % len(pool)]
        path = folder / f"case{n}_{name}"
        path.write_bytes(mutate(data, rng))
        if n % NAMED_EVERY == NAMED_EVERY - 1:  # a problem file naming its own output
            (outcome, why), seconds = bounded(functools.partial(named_input_case, folder, rng, clip))
            name = "named inputs"
        elif kind == "table":
            (outcome, why), seconds = bounded(functools.partial(read_table, path, name, skeleton))
        else:
            status, err, seconds = run_case(path, kind)
            outcome, why = ("ok" if status == 0 else "error"), problem_with(status, err, path)
        slowest = max(slowest, seconds)
        if why:
            failures.append({"case": n, "seed_file": name, "why": why})
        else:
            outcomes[outcome] += 1
        if path.is_dir():
            path.rmdir()
        elif path.exists() or path.is_symlink():
            path.unlink()
    return {
        "cases": cases,
        "outcomes": outcomes,
        "failures": failures,
        "slowest_case_s": slowest,
        "seed_files": [name for name, _, _ in pool],
    }


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--cases", type=int, default=3000)
    p.add_argument("--memory-gib", type=float, default=6.0, help="address-space bound of this process (GiB)")
    run = harness.start("fuzz_cli", p, argv)
    args = run.args
    # a case that allocates without bound fails with MemoryError (an internal error) instead of
    # exhausting the machine
    resource.setrlimit(resource.RLIMIT_AS, (int(args.memory_gib * 2**30), resource.RLIM_INFINITY))
    with tempfile.TemporaryDirectory() as folder:
        found = fuzz(args.cases, args.seed, Path(folder))
    run.target("cases that break the rules", 0, len(found["failures"]), "cases", at_most=True)
    counts = {"result": found["outcomes"]["ok"], "one-line error": found["outcomes"]["error"]}
    counts["broke a rule"] = len(found["failures"])
    fig, axes = harness.figure()
    harness.bars(axes[0, 0], list(counts), list(counts.values()))
    harness.style_axes(axes[0, 0], "", "cases", f"{found['cases']} mutated inputs through the CLI", False, False)
    body = harness.md_table(["outcome", "cases"], [[k, v] for k, v in counts.items()])
    body += "".join(f"\n- case {f['case']} ({f['seed_file']}): {f['why']}" for f in found["failures"][:20])
    run.finish(found, body, fig, counts)
    return 1 if found["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
