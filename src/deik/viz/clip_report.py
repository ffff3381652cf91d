"""The clip report picture: the frame the fix changed most, before and after, with its contacts and
reach targets (front and side views or one 3-D perspective view, axes in the clip's unit), above
each per-frame error series before and after the fix, over time.

Written as one PNG, one subplot per series stacked over a shared time axis (seconds below,
frame numbers above), atomically: a reader sees the old file or the complete new one.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from deik.errors import InputError
from deik.io.atomic import save_atomically
from deik.io.files import FilePath
from deik.io.motion import Clip
from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.viz.marks import colour
from deik.viz.plot import add_pose_axes, require_matplotlib
from deik.viz.pose_axes import draw_skeleton, fit_axes
from deik.viz.report_marks import marks_at

if TYPE_CHECKING:  # matplotlib is imported when a picture is drawn
    from matplotlib.figure import Figure

POSE_HEIGHT = 4.5  # inches of the picture the pose panel takes
SERIES_HEIGHT = 2.0  # inches per error series
WIDTH = 9.0  # inches
# Characters per line of the title (12 pt: about 7 pt a character, 9 inches less margins) and of
# a series' name beside its axes (10 pt, along SERIES_HEIGHT less the gaps between series).
TITLE_CHARACTERS, LABEL_CHARACTERS = 80, 22


@dataclass(frozen=True, eq=False)
class PosePanel:
    """One frame of a fix drawn above the series: the clip's `skeleton`, its pose `before` and
    `after` the fix (D,), the `frame` number, `marks` {kind: points (N, 3)} (contact plants,
    reach targets), the `projection` ("2d" or "3d") and the length `unit`."""

    skeleton: Skeleton
    before: np.ndarray
    after: np.ndarray
    frame: int
    marks: dict
    projection: str = "2d"
    unit: str = "m"


def most_changed_frame(original: Motion, fixed: Motion) -> int:
    """The frame of two clips (deik.Clip, same skeleton and length) whose joints and sites lie
    farthest apart on average: where the fix did the most."""
    before, after = original.kinematics.p_world_frame, fixed.kinematics.p_world_frame
    return int(np.argmax(np.linalg.norm(after - before, axis=-1).mean(axis=1)))


def pose_panel(original: Clip, fixed: Clip, document: dict, projection: str = "2d", unit: str = "m") -> PosePanel:
    """The PosePanel of a fix's most changed frame, marked with the contacts and reach targets
    of its report `document` (deik.cleanup.document.clip_document)."""
    frame = most_changed_frame(original, fixed)
    marks = marks_at(document, frame, original.n_frames)
    return PosePanel(fixed.skeleton, original.pose(frame), fixed.pose(frame), frame, marks, projection, unit)


def _draw_pose(container, panel: PosePanel) -> None:
    """The panel's frame: the pose before the fix in grey under the pose after, with its marks."""
    sk = panel.skeleton
    points = forward_kinematics(sk, np.stack([panel.before, panel.after])).p_world_frame
    for k, (ax, basis) in enumerate(add_pose_axes(container, sk, panel.projection, panel.unit)):
        under = draw_skeleton(ax, basis, sk, points[0], None, "compare", True, "before")
        over = draw_skeleton(ax, basis, sk, points[1], panel.marks, bone_label="after")
        fit_axes(ax, np.concatenate([under, over]))
        if k == 0:
            ax.legend(loc="upper left", fontsize="x-small", markerscale=0.8)
    container.suptitle(f"frame {panel.frame}, where the fix moved the body most: before (grey) and after")


def clip_report_figure(
    series: dict,
    frame_time: float,
    title: str = "",
    notes: Sequence[str] = (),
    pose: PosePanel | None = None,
) -> Figure:
    """The matplotlib Figure plot_clip_report saves (see there); the caller closes it."""
    if not series:
        raise InputError("there is no error series to plot")
    if not frame_time > 0:
        raise InputError(f"frame_time must be a positive number of seconds, got {frame_time}")
    lines = {}
    for name, (before, after) in series.items():
        before, after = np.asarray(before, float), np.asarray(after, float)
        if before.shape != after.shape or before.ndim != 1:
            raise InputError(
                f"series {name!r}: before and after must be (N,) arrays of one "
                f"length, got {before.shape} and {after.shape}"
            )
        lines[name] = before, after
    plt = require_matplotlib()
    height = 1.2 + SERIES_HEIGHT * len(lines)
    figure = plt.figure(layout="constrained", figsize=(WIDTH, height + (POSE_HEIGHT if pose is not None else 0.0)))
    container = figure
    if pose is not None:
        top, container = figure.subfigures(2, 1, height_ratios=[POSE_HEIGHT, height])
        _draw_pose(top, pose)
    axes = container.subplots(len(lines), 1, sharex=True, squeeze=False)
    for ax, (name, (before, after)) in zip(axes[:, 0], lines.items()):
        time = np.arange(len(before)) * frame_time
        # markers keep frames between NaN gaps (e.g. a sparse reach track) visible
        ax.plot(time, before, ".-", color=colour("compare"), lw=1.5, ms=3, label="before")
        ax.plot(time, after, ".-", color="tab:blue", lw=1.5, ms=3, label="after")
        # a long name in lines of a few words, so that it stays beside its own series
        ax.set_ylabel(textwrap.fill(name, LABEL_CHARACTERS), fontsize="small")
        ax.grid(alpha=0.3)
    top_series = axes[0, 0]
    top_series.legend(loc="upper right", fontsize="small")
    frames = (lambda t: t / frame_time, lambda n: n * frame_time)
    top_series.secondary_xaxis("top", functions=frames).set_xlabel("frame")
    axes[-1, 0].set_xlabel("time (s)")
    # every line of the title and notes wrapped to the figure's width
    text = [textwrap.fill(line, TITLE_CHARACTERS) for line in [title or "clip errors before and after", *notes]]
    figure.suptitle("\n".join(text), fontsize="medium")
    return figure


def plot_clip_report(
    series: dict,
    path: FilePath,
    frame_time: float,
    title: str = "",
    notes: Sequence[str] = (),
    pose: PosePanel | None = None,
) -> None:
    """Draw `series` {name: (before (N,), after (N,))} (e.g. from clips.report.per_frame_errors;
    NaN frames are left blank) to PNG `path`; `frame_time` seconds per frame sets the time axis;
    `notes`: lines of text under the title (numbers that are not series); `pose`: a PosePanel
    drawn above the series, or None."""
    figure = clip_report_figure(series, frame_time, title, notes, pose)
    plt = require_matplotlib()
    try:
        save_atomically(path, lambda file: figure.savefig(file, format="png", dpi=100))
    finally:
        plt.close(figure)
