"""A clip report (`deik clip --json`, deik.cleanup.document) as marks on a clip's scene: each
contact's plant point while it touches, each reach track's target in its frames, and the floor.

Every mistake in the report is a FileFormatError (a ValueError) that names the file.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from deik.errors import FileFormatError
from deik.io.files import FilePath, read_json
from deik.viz.scene import Marks, Scene

WHAT = "clip report (JSON)"
FIX = "give the file `deik clip --json` wrote for this clip"


def read_clip_report(path: FilePath) -> dict:
    """The report at `path`, checked for the keys the view reads."""
    path = str(path)
    document = read_json(path, WHAT)
    if not isinstance(document, dict) or not isinstance(document.get("frames"), int):
        raise FileFormatError(path, f'is no clip report: it has no "frames" count; {FIX}')
    return document


def _point(path: str, value, what: str) -> np.ndarray:
    try:
        point = np.asarray(value, float)
    except (TypeError, ValueError):
        point = np.empty(0)
    if point.shape != (3,) or not np.isfinite(point).all():
        raise FileFormatError(path, f"{what} must be 3 finite numbers, got {value!r}; {FIX}")
    return point


def _contacts(path: str, record, steps: int) -> Marks | None:
    """One "contact" mark per site in contact: its plant point over each contact's frames."""
    if not record:
        return None
    try:
        sites = [(entry["site"], entry["contacts"]) for entry in record["sites"]]
        spans = [[(c["first_frame"], c["last_frame"], c["plant"]) for c in contacts] for _, contacts in sites]
    except (KeyError, TypeError):
        problem = '"contacts" must list each site with its contacts, their frames and plants'
        raise FileFormatError(path, f"{problem}; {FIX}") from None
    points = np.full((steps, len(sites), 3), np.nan)
    for k, ((site, _), runs) in enumerate(zip(sites, spans)):
        for first, last, plant in runs:
            if not (isinstance(first, int) and isinstance(last, int) and 0 <= first <= last < steps):
                raise FileFormatError(path, f"contact of {site!r}: frames {first}-{last} are outside the clip; {FIX}")
            points[first : last + 1, k] = _point(path, plant, f"contact plant of {site!r}")
    return Marks("contact", tuple(site for site, _ in sites), points)


def _reach(path: str, tracks, steps: int) -> Marks | None:
    """One "target" mark per reach track: its target in the frames it applies to."""
    if not tracks:
        return None
    points = np.full((steps, len(tracks), 3), np.nan)
    labels = []
    for k, track in enumerate(tracks):
        frames, targets = track.get("frames", []), track.get("targets", [])
        if len(frames) != len(targets) or not all(isinstance(f, int) and 0 <= f < steps for f in frames):
            raise FileFormatError(path, f"reach track of {track.get('site')!r} has bad frames or targets; {FIX}")
        for frame, target in zip(frames, targets):
            points[frame, k] = _point(path, target, f"reach target of {track.get('site')!r}")
        labels.append(f"reach {track.get('site')}")
    return Marks("target", tuple(labels), points)


def _report_marks(document: dict, path: str, steps: int) -> list[Marks]:
    """The report's contact and reach marks over a clip of `steps` frames."""
    marks = (_contacts(path, document.get("contacts"), steps), _reach(path, document.get("reach_targets"), steps))
    return [m for m in marks if m is not None]


def marks_at(document: dict, frame: int, steps: int, path: str = "the clip report") -> dict:
    """{kind: points (K, 3)} of the report's contacts and reach targets in `frame` of a clip of
    `steps` frames (those that apply there; NaN rows are left out)."""
    out = {}
    for marks in _report_marks(document, path, steps):
        points = marks.points[frame]
        points = points[np.isfinite(points).all(axis=1)]
        out[marks.kind] = np.concatenate([out[marks.kind], points]) if marks.kind in out else points
    return out


def with_clip_report(scene: Scene, document: dict, path: FilePath) -> Scene:
    """`scene` (a clip's, one step per frame) with the report's contacts, reach targets, floor
    and length unit; ValueError naming `path` when the report is for a clip of another length."""
    path = str(path)
    if document["frames"] != scene.n_steps:
        raise FileFormatError(
            path, f"reports a clip of {document['frames']} frames, the viewed clip has {scene.n_steps}; {FIX}"
        )
    marks = _report_marks(document, path, scene.n_steps)
    floor = document.get("floor") or {}
    height = floor.get("height") if isinstance(floor, dict) else None
    notes = list(scene.notes)
    if isinstance(document.get("frames_met"), int):
        notes.append(f"{document['frames_met']}/{document['frames']} frames met every goal of the fix")
    unit = document.get("length_unit")
    return replace(
        scene,
        marks=scene.marks + tuple(marks),
        floor=float(height) if isinstance(height, (int, float)) else scene.floor,
        unit=unit if isinstance(unit, str) else scene.unit,
        unit_source="the clip report" if isinstance(unit, str) else scene.unit_source,
        notes=tuple(notes),
    )
