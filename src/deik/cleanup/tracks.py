"""Target tracks for reach goals: where a site should be, frame by frame.

A track file is CSV or JSON (told apart by its first character: `[` or `{` means JSON):
- CSV: a header naming the columns `frame`, `x`, `y`, `z` in any order (any case, extra
  columns ignored), then one row per frame; fields separated by commas with optional spaces;
  blank lines are skipped.
- JSON: a list of {"frame": n, "x": .., "y": .., "z": ..}, or {"frames": [n, ...],
  "positions": [[x, y, z], ...]}.
Frames are 0-based clip frames; positions are world coordinates in the clip's length unit.
Frames the track does not list are inactive. Malformed files raise FileFormatError naming the
file and the line (CSV) or element (JSON).
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

from deik.errors import FileFormatError, InputError
from deik.io.bvh.hierarchy import number
from deik.io.files import MAX_NUMBER, FilePath, integer_value, number_value, parse_csv, parse_json, read_input_text

COLUMNS = ("frame", "x", "y", "z")
SPEC_FORMS = (
    "SITE=track.csv, SITE=track.json, or SITE=X,Y,Z@A:B (a fixed point over frames "
    "A..B inclusive; without @A:B, the whole clip)"
)
FRAME_RANGE = re.compile(r"\s*(\d{1,12})\s*:\s*(\d{1,12})\s*")  # 12 digits: no clip is longer


def _valid_frames(n_frames: int) -> str:
    return f"0..{n_frames - 1}" if n_frames else "none: the clip has no frames"


def _csv_rows(source: str, text: str) -> list[tuple[int, list[str]]]:
    """[(line, [frame, x, y, z])] of a CSV track, values still text."""
    lines = parse_csv(text, source)
    if not lines:
        raise FileFormatError(source, "empty track: expected a header frame,x,y,z and rows")
    header_line, header = lines[0]
    names = [name.lower() for name in header]
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise FileFormatError(
            source,
            f"missing column{'s' if len(missing) > 1 else ''} "
            f"{', '.join(missing)}: the header must name frame, x, y and z",
            line=header_line,
        )
    where = [names.index(c) for c in COLUMNS]
    rows = []
    for n, fields in lines[1:]:
        if len(fields) != len(names):
            raise FileFormatError(source, f"{len(fields)} fields where the header has {len(names)}", line=n)
        rows.append((n, [fields[k] for k in where]))
    return rows


def _csv_values(source: str, rows) -> list[tuple[str, int, int, list[float]]]:
    """[(where, line, frame, [x, y, z])] of the CSV rows, checked numbers."""
    values = []
    for n, (frame, *xyz) in rows:
        if not re.fullmatch(r"[+-]?\d{1,12}", frame):
            raise FileFormatError(source, f"frame {frame!r:.40} is not a whole number", line=n)
        point = [number(source, v, n, f"column {c}") for c, v in zip("xyz", xyz)]
        values.append((f"line {n}", n, int(frame), point))
    return values


def _json_value(source: str, where: str, value, integer: bool):
    """A JSON frame (integer) or coordinate (finite number) checked, else FileFormatError."""
    if integer:
        return integer_value(value, source, where, -(2**62), 2**62)  # the clip's range is checked later
    return number_value(value, source, where)


def _json_values(source: str, text: str) -> list[tuple[str, None, int, list[float]]]:
    """[(element, None, frame, [x, y, z])] of a JSON track (see the module notes)."""
    data = parse_json(text, source, "track")
    if isinstance(data, dict) and {"frames", "positions"} <= set(data):
        frames, positions = data["frames"], data["positions"]
        if not isinstance(frames, list) or not isinstance(positions, list) or len(frames) != len(positions):
            raise FileFormatError(
                source, '"frames" and "positions" must be lists of the same length', element="positions"
            )
        items = []
        for k, (frame, point) in enumerate(zip(frames, positions)):
            if not isinstance(point, list) or len(point) != 3:
                raise FileFormatError(source, f"must be [x, y, z], got {point!r:.60}", element=f"positions[{k}]")
            coordinates = [(f"positions[{k}][{j}]", v) for j, v in enumerate(point)]
            items.append((f"frames[{k}]", frame, coordinates))
    elif isinstance(data, list):
        items = []
        for k, item in enumerate(data):
            missing = [c for c in COLUMNS if not isinstance(item, dict) or c not in item]
            if missing:
                raise FileFormatError(
                    source,
                    f'missing {", ".join(missing)}: each element needs "frame", "x", "y" and "z"',
                    element=f"[{k}]",
                )
            items.append((f"[{k}].frame", item["frame"], [(f"[{k}].{c}", item[c]) for c in "xyz"]))
    else:
        raise FileFormatError(
            source,
            'expected a list of {"frame", "x", "y", "z"} objects or an object with "frames" and "positions"',
            element="top level",
        )
    return [
        (
            where,
            None,
            _json_value(source, where, frame, True),
            [_json_value(source, at, v, False) for at, v in coordinates],
        )
        for where, frame, coordinates in items
    ]


def read_track(path: FilePath, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Read the track file at `path` (see the module notes) for a clip of `n_frames`.

    Returns mask (N,) bool, the frames the track lists, and targets (N, 3) in length units,
    NaN where the mask is False. FileFormatError for missing columns, non-numbers, NaN,
    repeated frames, frames outside 0..N-1 and tracks that list no frame.
    """
    source = str(path)
    text = read_input_text(path, "track")
    if text.lstrip()[:1] in ("[", "{") or source.lower().endswith(".json"):
        values = _json_values(source, text)
    else:
        values = _csv_values(source, _csv_rows(source, text))
    if not values:
        raise FileFormatError(source, "empty track: it lists no frames")
    mask = np.zeros(n_frames, dtype=bool)
    targets = np.full((n_frames, 3), np.nan)
    seen = {}
    for where, line, frame, point in values:
        element = None if line is not None else where
        if not 0 <= frame < n_frames:
            raise FileFormatError(
                source,
                f"frame {frame} is outside the clip; valid frames: {_valid_frames(n_frames)}",
                line=line,
                element=element,
            )
        if frame in seen:
            raise FileFormatError(
                source, f"frame {frame} is listed twice (first at {seen[frame]})", line=line, element=element
            )
        seen[frame] = where
        mask[frame] = True
        targets[frame] = point
    return mask, targets


def _fixed_point(spec: str, value: str, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    point_text, at, span = value.partition("@")
    try:
        point = [float(v) for v in point_text.split(",")]
    except ValueError:
        point = []
    if len(point) != 3 or not all(map(math.isfinite, point)):
        raise InputError(
            f"reach {spec!r}: {point_text!r} is not a point X,Y,Z of three finite "
            f"numbers and not a .csv or .json track; the accepted forms are "
            f"{SPEC_FORMS}"
        )
    if max(map(abs, point)) > MAX_NUMBER:
        raise InputError(f"reach {spec!r}: {point_text!r} is out of range: give numbers from -1e+12 to 1e+12")
    first, last = 0, n_frames - 1
    if at:
        match = FRAME_RANGE.fullmatch(span)
        if not match:
            raise InputError(
                f"reach {spec!r}: frame range {span!r} is not A:B (two whole "
                f"numbers, B inclusive); the accepted forms are {SPEC_FORMS}"
            )
        first, last = int(match[1]), int(match[2])
        if not 0 <= first <= last < n_frames:
            raise InputError(
                f"reach {spec!r}: frames {first}:{last} are outside the clip or "
                f"reversed; valid frames: {_valid_frames(n_frames)}"
            )
    mask = np.zeros(n_frames, dtype=bool)
    mask[first : last + 1] = True
    targets = np.full((n_frames, 3), np.nan)
    targets[mask] = point
    return mask, targets


def track_file(spec: str) -> str | None:
    """The track file a --reach SITE=TARGET argument names (TARGET ending in .csv or .json, or
    any path that exists), or None for a fixed point X,Y,Z[@A:B]."""
    value = spec.partition("=")[2].strip()
    if os.path.splitext(value)[1].lower() in (".csv", ".json") or os.path.lexists(value):
        return value
    return None


def parse_reach_spec(spec: str, n_frames: int) -> tuple[str, np.ndarray, np.ndarray]:
    """A --reach argument -> (site name, mask (N,) bool, targets (N, 3) length units, NaN
    where inactive). Forms: SITE=track.csv, SITE=track.json (or any existing file: see
    read_track) and SITE=X,Y,Z@A:B, a fixed point over frames A..B inclusive (the whole clip
    without @A:B). InputError naming the accepted forms when malformed; the site name is not
    checked here."""
    site, equals, value = spec.partition("=")
    site, value = site.strip(), value.strip()
    if not equals or not site or not value:
        raise InputError(f"reach {spec!r} is not SITE=TARGET; the accepted forms are {SPEC_FORMS}")
    if track_file(spec) is not None:
        mask, targets = read_track(value, n_frames)
    else:
        mask, targets = _fixed_point(spec, value, n_frames)
    return site, mask, targets
