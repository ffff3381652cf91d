"""The fuzz harness's second half (benchmarks/fuzz_cli.py runs both): the JSON, TOML and CSV files
deik reads beside clips and robots, mutated and read by their readers, and problem files that
name their own output.

- Tables (benchmarks/fuzz_seeds/): a segment table, a limits table, reach tracks (CSV and JSON),
  a joint map (TOML) and a library record (a sidecar), each mutated as fuzz_cli mutates its
  seeds (plus scale extremes and numbers of hundreds or thousands of digits) and read by its
  reader in this process: each must
  end in a result or one deik InputError naming the file; a library record, which deik writes
  itself, must never raise at all (a damaged one is reported and its clip redone).
- Inputs named inside other inputs: a problem file names the clip, limits or segments it reads,
  and `deik solve --problem` is asked to write its output over one of them: the command must
  refuse (exit 2, one line) and leave the file byte for byte.
"""

from __future__ import annotations

import contextlib
import io
import random
import re
from pathlib import Path

from deik.cli import main as deik_main
from deik.errors import InputError

SEEDS = Path(__file__).resolve().parent / "fuzz_seeds"
TABLES = ("segments.json", "limits.json", "track.csv", "track.json", "map.toml", "record.json")
HUGE = ["1e300", "-1e300", "1" + "0" * 400, "9" * 5000, "-1e-3", "1e-300"]


def table_seeds() -> list[tuple[str, str, bytes]]:
    """(name, kind, content) of every table seed (benchmarks/fuzz_seeds/): kind "table"."""
    return [(name, "table", (SEEDS / name).read_bytes()) for name in TABLES]


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
