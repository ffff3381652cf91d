"""Plain-text views: aligned tables and the unit of a goal report."""

from __future__ import annotations

RADIAN_WORDS = ("orientation", "aim", "comfort")


def format_table(header: list[str], rows: list[list]) -> str:
    """Left-aligned text table: `header` column names, `rows` of cells turned into strings."""
    cells = [header] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[k]) for row in cells) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in cells]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths)] + lines[1:])


def unit(label: str) -> str:
    """Unit of a goal report's error from its label: "rad" for angles, "m" for lengths."""
    return "rad" if label.split()[0] in RADIAN_WORDS else "m"
