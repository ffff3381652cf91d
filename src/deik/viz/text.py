"""Plain-text views: aligned tables."""

from __future__ import annotations


def format_table(header: list[str], rows: list[list]) -> str:
    """Left-aligned text table: `header` column names, `rows` of cells turned into strings."""
    cells = [header] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[k]) for row in cells) for k in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in cells]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths)] + lines[1:])
