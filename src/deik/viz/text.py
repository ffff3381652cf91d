"""Plain-text views: aligned tables, and values shown in the units reports use."""

from __future__ import annotations

import math


def format_table(header: list[str], rows: list[list]) -> str:
    """Left-aligned text table: `header` column names, `rows` of cells turned into strings."""
    cells = [header] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[k]) for row in cells) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in cells]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths)] + lines[1:])


def shown(value: float, unit: str, length: str = "m") -> str:
    """`value` of a goal error or tolerance in `unit` ("m", "rad" or "rad+m": GoalReport.unit) as
    reports show it: angles in degrees (docs/conventions.md), lengths in `length`, the name of
    the skeleton's length unit (viz.marks.length_unit: "m", "cm", "link lengths", ...), which
    the "m" of a goal's unit stands for; 6 digits."""
    if unit == "rad":
        return f"{math.degrees(value):.6g} deg"
    return f"{value:.6g} {unit.replace('m', length) if unit in ('m', 'rad+m') else unit}"


def figure(value: float | None, form: str = ".4g") -> str:
    """`value` to `form`, or "-" when it was not measured (None, or NaN: a clip too short for an
    acceleration, a measure with nothing to measure)."""
    return "-" if value is None or not math.isfinite(value) else f"{value:{form}}"


def frame_spans(frames: list[int]) -> str:
    """Frames as inclusive ranges: [3, 4, 5, 9] -> "3-5, 9"."""
    runs, start = [], frames[0]
    for a, b in zip(frames, frames[1:] + [None]):
        if b != a + 1:
            runs.append(f"{start}-{a}" if a > start else f"{a}")
            start = b
    return ", ".join(runs)


def _frames(frames: list[int]) -> str:
    """ "frame 3" or "frames 3-5, 9"."""
    return f"frame{'s' if len(frames) > 1 else ''} {frame_spans(frames)}"


SEAMS_SHOWN = 5  # seams a summary names; --json lists them all


def cut_lines(record: dict, fates: tuple[str, str, str]) -> list[str]:
    """Lines on the cuts of a capture (deik.cleanup.cuts.Cuts.record): its bind poses, its
    glitches and its seams, each followed by what became of it, `fates` (bind, glitch, seam)."""
    lines = []
    if record["kept_frames"]:
        lines.append(f"{_frames(record['kept_frames'])}: a pose the motion jumps from or to (a bind pose); {fates[0]}")
    if record["bridged_frames"]:
        lines.append(f"{_frames(record['bridged_frames'])}: the pose jumps away and back (a glitch); {fates[1]}")
    seams = record["between_takes"]
    if seams:
        pairs = ", ".join(f"{n} and {n + 1}" for n in seams[:SEAMS_SHOWN])
        more = f" and {len(seams) - SEAMS_SHOWN} more" if len(seams) > SEAMS_SHOWN else ""
        lines.append(
            f"the pose jumps between frames {pairs}{more} (a seam where two takes, or a loop's end and start, "
            f"meet); {fates[2]}"
        )
    return lines
