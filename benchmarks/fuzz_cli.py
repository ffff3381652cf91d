"""Fuzz the command line with mutated input files: every case must end in a result or one line
`deik: error: FILE...` (exit 2), never a traceback, an internal error, a hang or a crash.

Seeds: a small BVH clip, a small URDF arm and a TOML problem (benchmarks/fuzz_seeds/), plus the
BVH and URDF files of the shared data when present, and the tables read beside them (a segment
table, a limits table, reach tracks in CSV and JSON, a joint map in TOML and a library record),
read by their readers in this process: a table must end in a result or one deik InputError
naming the file, and a library record, which deik writes itself, must never raise (a damaged
one is reported and its clip redone). One case in NAMED_EVERY is a problem file that names the
clip, limits or segments it reads and is solved with --out over one of them: the command must
refuse (exit 2, one line) and leave the file byte for byte. Each case mutates one seed (a
flipped byte, a deleted, doubled or truncated line, scale extremes, a number swapped for NaN,
1e308, 1e300, 1_000, 0x10, 5,000 digits or nothing, CR-only line endings, deep nesting) and
runs `deik info` (BVH, URDF) or `deik solve --problem` (TOML) in this process, with an alarm as
the time bound and an address-space limit as the memory bound. The same seed gives the same cases.

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
from deik.cli import main as deik_main
from deik.errors import InputError
from deik.io.bvh import parse_bvh

SEEDS = Path(__file__).resolve().parent / "fuzz_seeds"
CASE_SECONDS = 30  # a case running longer counts as a hang
NAMED_EVERY = 25  # one case in this many is a problem file that names its own output
TABLES = ("segments.json", "limits.json", "track.csv", "track.json", "map.toml", "record.json")
HUGE = ["1e300", "-1e300", "1" + "0" * 400, "9" * 5000, "-1e-3", "1e-300"]  # -1e-3: a number, not an option
NASTY = ["nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "1_000", "0x10", "", "-0", "99999999999999999999"]
NASTY += ["1e5e5", "e5", "true", "[]", '"x"', "{", "}", "-", ".", *HUGE]
NUMBER = re.compile(r"-?\d+(\.\d+)?(e-?\d+)?")


def seeds() -> list[tuple[str, str, bytes]]:
    """(name, kind, content) of every seed file: our own, the tables (kind "table"), then the
    shared BVH and URDFs."""
    shared = shared_data()
    paths = [SEEDS / f"seed.{kind}" for kind in ("bvh", "urdf", "toml")]
    paths += sorted(shared.glob("humanoid/*.bvh"))[:3] + sorted(shared.glob("robots/*.urdf"))
    ours = [(path.name, path.suffix[1:], path.read_bytes()) for path in paths]
    return ours[:3] + [(name, "table", (SEEDS / name).read_bytes()) for name in TABLES] + ours[3:]


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


def scaled(data: bytes, rng: random.Random) -> bytes:
    """`data` with every number multiplied by one power of ten from 1e-12 to 1e12 (scale extremes)."""
    factor = 10.0 ** rng.choice([-12, -6, -3, 3, 6, 12])
    text = data.decode("latin-1")
    number = re.compile(r"(?<![\w.])-?\d+\.?\d*(?:[eE][+-]?\d+)?")
    return number.sub(lambda m: repr(float(m.group()) * factor), text).encode("latin-1")


def read_table(path: Path, seed_name: str, skeleton) -> tuple[str, str | None]:
    """Read mutated table `path` (a copy of seed `seed_name`) with its reader: (outcome "ok" or
    "error", why it broke the rules or None: a result, or an InputError naming the file)."""
    from deik.cleanup.tracks import read_track
    from deik.io.limits import read_limits
    from deik.io.segments import read_segment_table
    from deik.library.jobs import Job, read_sidecar
    from deik.retargeting.maps import read_map

    if seed_name == "record.json":
        job = Job("seed.bvh", "seed.bvh", (), str(path), "0" * 64, {})
        try:
            document, damage = read_sidecar(job)
        except Exception as error:  # noqa: BLE001 - any exception breaks the rule
            return "error", f"a damaged record raised {type(error).__name__}: {error}"[:300]
        if document is None and path.name not in damage and damage:
            return "error", f"the damage report does not name the record: {damage[:300]}"
        return ("ok" if document is not None else "error"), None
    readers = {
        "segments.json": lambda: read_segment_table(path, skeleton.joint_names),
        "limits.json": lambda: read_limits(path, skeleton),
        "track.csv": lambda: read_track(path, 3),
        "track.json": lambda: read_track(path, 3),
        "map.toml": lambda: read_map(path),
    }
    try:
        readers[seed_name]()
    except (InputError, KeyError) as error:
        message = str(error.args[0] if isinstance(error, KeyError) else error)
        return "error", None if path.name in message else f"the message does not name the file: {message[:300]}"
    except Exception as error:  # noqa: BLE001 - any other exception breaks the rule
        return "error", f"{type(error).__name__}: {error}"[:300]
    return "ok", None


def named_input_case(folder: Path, rng: random.Random, bvh: bytes) -> tuple[str, str | None]:
    """A problem file naming a clip, limits and segments, solved with --out over one of them:
    ("error", why the outcome broke the rules or None: exit 2, one line, the file unchanged)."""
    (folder / "named.bvh").write_bytes(bvh)
    (folder / "named_limits.json").write_bytes((SEEDS / "limits.json").read_bytes())
    (folder / "named_segments.json").write_bytes((SEEDS / "segments.json").read_bytes())
    problem = folder / "named.toml"
    problem.write_text(
        'skeleton = "named.bvh"\nframe = 0\njoint_limits = "named_limits.json"\nsegments = "named_segments.json"\n'
        '[settings]\ngenerations = 2\n[[goal]]\ntype = "position"\nframe = "Spine_end"\ntarget = [0.0, 1.4, 0.1]\n'
    )
    target = folder / rng.choice(["named.bvh", "named_limits.json", "named_segments.json"])
    out = target.with_suffix(".json") if target.suffix == ".json" else target  # --out takes .json or .bvh
    before = out.read_bytes()
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = deik_main(["solve", "--problem", str(problem), "--out", str(out)])
    if out.read_bytes() != before:
        return "error", f"--out {out.name}, named inside the problem file, was overwritten (exit {status})"
    if status != 2 or err.getvalue().count("\n") != 1 or out.name not in err.getvalue():
        return "error", f"exit {status}, not one line naming {out.name}: {err.getvalue()[:300]!r}"
    return "error", None


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
