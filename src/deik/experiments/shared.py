"""Shared plumbing of the paper-reproduction experiments: seeds, statistics, outputs.

Every experiment returns a `Section` (the paper's claim, our measurement, the command and the
differences) and writes NAME.png, NAME.csv and NAME.md into its output folder, each file
atomically (`deik.io.atomic`). Statistics are medians with quartiles and min/max over a fixed
list of seeds; a run that never reached its bound counts as +inf (shown "never"), so it moves
the quartiles instead of being dropped.
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from deik.io.atomic import save_atomically, scratch, write_text_atomically
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.solver.settings import Settings
from deik.viz.plot import plot_result, require_matplotlib

if TYPE_CHECKING:  # matplotlib is imported when a picture is drawn
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

CONVERGED_FRACTION = 0.01  # the paper's criterion: within 1 % of the chain's reach
# The figures measure the paper's subject, DE itself: the LM polish, jDE rates and restarts
# that deik adds by default are off, so every column is evolution alone.
DE_ONLY = {"polish": 0, "adaptive": False, "restarts": 0}


def de_only(**settings: object) -> Settings:
    """deik's default current-to-best/1/bin DE without polish, jDE or restarts."""
    return Settings(**{**DE_ONLY, **settings})


def seed_list(quick: bool, full: int, fast: int) -> list[int]:
    """The fixed seeds of an experiment: 0 .. n-1 with n = `fast` when quick, else `full`."""
    return list(range(fast if quick else full))


def quantile(values: ArrayLike, q: float) -> float:
    """Linear-interpolation quantile q in [0, 1] of `values` (n,) that may hold +inf (runs
    that never converged); a quantile touching an inf is inf, never NaN."""
    v = np.sort(np.asarray(values, dtype=np.float64))
    if v.size == 0:
        return math.nan
    pos = q * (v.size - 1)
    lo, hi = int(math.floor(pos)), int(math.ceil(pos))
    if math.isinf(v[lo]) or math.isinf(v[hi]):
        return math.inf
    return float(v[lo] + (v[hi] - v[lo]) * (pos - lo))


def spread(values: ArrayLike) -> dict:
    """{n, median, q1, q3, min, max, never}: `values` (n,), +inf marking non-converged runs
    (counted in `never`)."""
    v = np.asarray(values, dtype=np.float64)
    return {
        "n": int(v.size),
        "median": quantile(v, 0.5),
        "q1": quantile(v, 0.25),
        "q3": quantile(v, 0.75),
        "min": quantile(v, 0.0),
        "max": quantile(v, 1.0),
        "never": int(np.isinf(v).sum()),
    }


def number(x: float, digits: int = 3) -> str:
    """`x` with `digits` significant digits; inf as "never", NaN as "-"."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if math.isinf(x):
        return "never"
    return f"{x:.{digits}g}"


def describe(values: ArrayLike, digits: int = 3) -> str:
    """ "median [q1, q3]" of `values` (n,), e.g. "12 [8, 20]"."""
    s = spread(values)
    return f"{number(s['median'], digits)} [{number(s['q1'], digits)}, {number(s['q3'], digits)}]"


def markdown_table(header: list[str], rows: list[list]) -> str:
    """A GitHub markdown table: `header` (k,) column names, `rows` of k cells each (a "|" in a
    cell is escaped)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


def write_csv(path: str, rows: list[dict]) -> None:
    """Write `rows` (dicts with the same keys, in order) as CSV to `path`, atomically."""
    if not rows:
        raise ValueError(f"no rows to write to {path}")
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_text_atomically(path, buffer.getvalue())


def save_figure(figure: Figure, path: str, dpi: int = 110) -> None:
    """Save a matplotlib `figure` as PNG to `path` atomically and close it."""
    plt = require_matplotlib()
    try:
        save_atomically(path, lambda file: figure.savefig(file, format="png", dpi=dpi))
    finally:
        plt.close(figure)


def pose_panels(axes: Sequence[Axes], panels: Sequence[tuple[Problem, Result, str]]) -> None:
    """Draw pose pictures into `axes` (one per panel): each panel is (problem, unbatched
    Result, title), rendered by deik.viz.plot.plot_result into a temporary PNG and shown as an
    image, so experiments draw poses exactly as `deik solve --plot` does."""
    plt = require_matplotlib()
    with tempfile.TemporaryDirectory() as folder, scratch():  # read back at once, never an output
        for k, (ax, (problem, result, title)) in enumerate(zip(axes, panels)):
            path = os.path.join(folder, f"pose{k}.png")
            plot_result(problem, result, path, title=title)
            ax.imshow(plt.imread(path))
            ax.set_axis_off()


def command(name: str, quick: bool, extra: str = "") -> str:
    """The exact command that regenerates experiment `name` from a checkout."""
    flags = " --quick" if quick else ""
    return f"PYTHONPATH=src python -m deik.experiments {name}{flags}{extra} --out DIR"


@dataclass(kw_only=True)
class Section:
    """One figure's part of the report. `headline`: our measurement in one line for the
    side-by-side table; `measurement`, `differences`: markdown; `notes`: lines shown in bold
    (skipped GPU parts); `seconds`: wall time of the experiment."""

    name: str
    title: str
    claim: str
    headline: str
    measurement: str
    differences: str
    command: str
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def markdown(self, image: str | None = None) -> str:
        """The section as markdown; `image`: link to the PNG (default NAME.png beside it)."""
        image = image or f"{self.name}.png"
        parts = [
            f"## {self.title}",
            "",
            f"![{self.name}]({image})",
            "",
            f"**Paper.** {self.claim}",
            "",
            f"**Ours.** {self.headline}",
            "",
            self.measurement,
            "",
        ]
        parts += [f"**Note: {note}**\n" for note in self.notes]
        parts += [
            f"**Where and why we differ.** {self.differences}",
            "",
            f"Command ({self.seconds:.0f} s for this run):",
            "",
            "```sh",
            self.command,
            "```",
            "",
        ]
        return "\n".join(parts)

    def write(self, out_dir: str) -> None:
        """Write NAME.md into `out_dir`."""
        write_text_atomically(os.path.join(out_dir, f"{self.name}.md"), self.markdown())


def log_time_axes(ax: Axes, links: Sequence[int], title: str) -> None:
    """Log-log axes of seconds per generation against chain length, as Figs. 8-9 and the
    serial-vs-parallel benchmark draw them."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(links, [str(n) for n in links])
    ax.minorticks_off()
    ax.set_xlabel("links (DOFs)")
    ax.set_ylabel("seconds per generation")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
