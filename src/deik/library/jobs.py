"""One clip of a library as a job: its input, its outputs, the fingerprint of how they are made,
and the sidecar that records a finished job so that a rerun skips it.

A job is done when its sidecar (`OUTDIR/.NAME.deik.json`, NAME the clip's file name) holds the
job's fingerprint and every output it lists exists. The sidecar is hidden: the outputs are named
after clips, which are never hidden (deik.library.folder), so no output of any flag can share
its name. The fingerprint is a SHA-256 of the command, its settings (not how the run is shown:
--verbose, --progress), deik's version, the bytes of the input clip and of every file the
settings name (segment tables, limits, maps, targets, tracks, whatever their names end in) and
the output paths: a changed setting, input or output folder makes another fingerprint, and the
clip is redone. The sidecar is written atomically after the outputs (deik.io.atomic), so a job
killed before its sidecar is redone, never skipped. A damaged sidecar (not JSON, nested too
deeply, a wrong-typed field, a folder, a device or a pipe) is read as no record: that clip is
redone and the run says why.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from deik import __version__
from deik.errors import FileFormatError
from deik.io.atomic import NAME_MAX, write_json_atomically
from deik.io.files import Fields, FilePath, open_input, read_json

SIDECAR = ".deik.json"


class JobFailed(Exception):
    """A job could not be done; args[0] is the one-line reason shown in the summary."""


@dataclass(frozen=True)
class Job:
    """One clip to process: `name` its file name, `source` its path, `outputs` every file the
    job writes (absolute paths), `sidecar` where its record goes, `fingerprint` (see the module
    notes), `settings` the readable settings behind it, and `payload` what the task needs
    (picklable: it travels to worker processes)."""

    name: str
    source: str
    outputs: tuple[str, ...]
    sidecar: str
    fingerprint: str
    settings: dict
    payload: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Outcome:
    """What became of a job: `status` "done", "skipped" (up to date) or "failed", `seconds` of
    wall time in its worker (a skipped job's from its sidecar), `record` the task's record
    (frames, metrics; a skipped job's from its sidecar) or None, `reason` why it failed."""

    job: Job
    status: str
    seconds: float = 0.0
    record: dict | None = None
    reason: str = ""


# a task's frame progress: progress(frames done, frames in the clip)
FrameProgress = Callable[[int, int], None]
# a library task (deik.library.run): task(job.payload, progress) -> record
Task = Callable[[dict, FrameProgress], dict]
# what an executor yields: ("started", job), ("progress", job, done, total), ("finished", outcome)
Event = tuple[str, Job] | tuple[str, Job, int, int] | tuple[str, Outcome]


def file_digest(path: FilePath) -> str:
    """SHA-256 hex digest of a file's bytes (read as an input: a regular file of bounded size)."""
    digest = hashlib.sha256()
    with open_input(path, "input") as (file, _):
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fingerprint(command: str, settings: dict, source: str, files: dict, outputs: Iterable[FilePath]) -> str:
    """SHA-256 hex of `command`, `settings` (JSON-able), deik's version, the bytes of `source`
    and of `files` {setting: path} and the `outputs` paths."""
    record = {
        "command": command,
        "deik_version": __version__,
        "settings": settings,
        "source_sha256": file_digest(source),
        "files_sha256": {key: file_digest(path) for key, path in sorted(files.items())},
        "outputs": sorted(os.path.abspath(path) for path in outputs),
    }
    return hashlib.sha256(json.dumps(record, sort_keys=True, default=str).encode()).hexdigest()


def sidecar_path(folder: FilePath, name: str) -> str:
    """OUTDIR/.NAME.deik.json for the clip file `name` (hidden: see the module notes); for a name
    too long for that to fit a file system's NAME_MAX bytes, as much of it as fits and a digest
    of the whole (a clip may be named up to the limit, and its record must still be written)."""
    whole = f".{name}{SIDECAR}"
    if len(whole.encode()) > NAME_MAX:
        digest = "~" + hashlib.sha256(name.encode()).hexdigest()[:16]
        room = NAME_MAX - len(f".{digest}{SIDECAR}".encode())
        whole = f".{name.encode()[:room].decode('utf-8', 'ignore')}{digest}{SIDECAR}"
    return os.path.join(os.path.abspath(folder), whole)


def read_sidecar(job: Job) -> tuple[dict | None, str]:
    """(the sidecar of `job` when it records this very job (same fingerprint, every output
    present), else None; why a sidecar that is there cannot be used, "" when none is there or it
    records other settings or inputs)."""
    if not os.path.lexists(job.sidecar):
        return None, ""
    try:
        fields = Fields(read_json(job.sidecar, "library record", record=False), job.sidecar)
        if fields.text("fingerprint") != job.fingerprint:
            return None, ""
        document = {"seconds": fields.number("seconds", 0.0), "record": _record(fields.table("record"))}
    except FileFormatError as error:
        return None, f"its record is damaged ({error}); redoing the clip"
    return (document if all(os.path.isfile(path) for path in job.outputs) else None), ""


def _record(fields: Fields) -> dict:
    """A task's record from a sidecar, checked for the fields the summary reads."""
    record = dict(fields.data)
    for key in ("frames", "frames_met"):
        if key in fields:
            fields.integer(key)
    metrics = fields.table("metrics", {})
    if metrics:
        for key, value in metrics.data.items():
            if value is not None:
                metrics.number(key, -math.inf, math.inf)
    fields.text("printed", "")
    return record


def write_sidecar(job: Job, record: dict, seconds: float) -> None:
    """Record `job` as done (atomically; call it after its outputs are in place)."""
    document = {
        "fingerprint": job.fingerprint,
        "source": job.source,
        "outputs": list(job.outputs),
        "settings": job.settings,
        "deik_version": __version__,
        "seconds": seconds,
        "record": record,
    }
    write_json_atomically(job.sidecar, document, missing_as_null=True)


def skipped(job: Job) -> tuple[Outcome | None, str]:
    """(a "skipped" Outcome carrying the sidecar's record when `job` is done, else None; why a
    damaged sidecar is ignored, or "")."""
    document, damage = read_sidecar(job)
    if document is None:
        return None, damage
    return Outcome(job, "skipped", document["seconds"], document["record"]), ""
