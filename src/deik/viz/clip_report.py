"""The clip report picture: each per-frame error series before and after the fix, over time.

Written as one PNG, one subplot per series stacked over a shared time axis (seconds below,
frame numbers above), atomically: a reader sees the old file or the complete new one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from deik.io.atomic import save_atomically
from deik.io.files import FilePath
from deik.viz.plot import require_matplotlib


def plot_clip_report(
    series: dict[str, tuple[ArrayLike, ArrayLike]],
    path: FilePath,
    frame_time: float,
    title: str = "",
    notes: Sequence[str] = (),
) -> None:
    """Draw `series` {name: (before (N,), after (N,))} (e.g. from clips.report.per_frame_errors;
    NaN frames are left blank) to PNG `path`; `frame_time` seconds per frame sets the time axis;
    `notes`: lines of text under the title (numbers that are not series)."""
    if not series:
        raise ValueError("there is no error series to plot")
    if not frame_time > 0:
        raise ValueError(f"frame_time must be a positive number of seconds, got {frame_time}")
    lines = {}
    for name, (before, after) in series.items():
        before, after = np.asarray(before, float), np.asarray(after, float)
        if before.shape != after.shape or before.ndim != 1:
            raise ValueError(
                f"series {name!r}: before and after must be (N,) arrays of one "
                f"length, got {before.shape} and {after.shape}"
            )
        lines[name] = before, after
    plt = require_matplotlib()
    figure, axes = plt.subplots(
        len(lines), 1, sharex=True, squeeze=False, layout="constrained", figsize=(9.0, 1.2 + 2.0 * len(lines))
    )
    for ax, (name, (before, after)) in zip(axes[:, 0], lines.items()):
        time = np.arange(len(before)) * frame_time
        # markers keep frames between NaN gaps (e.g. a sparse reach track) visible
        ax.plot(time, before, ".-", color="0.55", lw=1.5, ms=3, label="before")
        ax.plot(time, after, ".-", color="tab:blue", lw=1.5, ms=3, label="after")
        ax.set_ylabel(name, fontsize="small")
        ax.grid(alpha=0.3)
    top = axes[0, 0]
    top.legend(loc="upper right", fontsize="small")
    top.secondary_xaxis("top", functions=(lambda t: t / frame_time, lambda n: n * frame_time)).set_xlabel("frame")
    axes[-1, 0].set_xlabel("time (s)")
    figure.suptitle("\n".join([title or "clip errors before and after", *notes]))
    try:
        save_atomically(path, lambda temporary: figure.savefig(temporary, format="png", dpi=100))
    finally:
        plt.close(figure)
