"""One clip of a library as a job: its input, its outputs, the fingerprint of how they are made,
and the sidecar that records a finished job so that a rerun skips it.

A job is done when its sidecar (`OUTDIR/NAME.deik.json`) holds the job's fingerprint and every
output it lists exists. The fingerprint is a SHA-256 of the command, its settings, deik's
version, the bytes of the input clip and of every file the settings name (segment tables,
limits, maps, targets, tracks) and the output paths: a changed setting, input or output folder
makes another fingerprint, and the clip is redone. The sidecar is written atomically after
the outputs (deik.io.atomic), so a job killed before its sidecar is redone, never skipped.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from deik import __version__
from deik.io.atomic import write_json_atomically
from deik.io.files import FilePath

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
    """SHA-256 hex digest of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
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
    """OUTDIR/STEM.deik.json for the clip file `name`."""
    return os.path.join(os.path.abspath(folder), os.path.splitext(name)[0] + SIDECAR)


def read_sidecar(job: Job) -> dict | None:
    """The sidecar of `job` when it records this very job (same fingerprint, every output
    present), else None (missing, unreadable, made otherwise, or an output gone)."""
    try:
        with open(job.sidecar, encoding="utf-8") as file:
            record = json.load(file)
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("fingerprint") != job.fingerprint:
        return None
    return record if all(os.path.isfile(path) for path in job.outputs) else None


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


def skipped(job: Job) -> Outcome | None:
    """A "skipped" Outcome carrying the sidecar's record when `job` is done, else None."""
    record = read_sidecar(job)
    if record is None:
        return None
    return Outcome(job, "skipped", float(record.get("seconds") or 0.0), record.get("record"))
