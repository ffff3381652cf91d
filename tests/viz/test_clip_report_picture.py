"""The clip report picture's pose panel: the frame the fix changed most, drawn before (grey) and
after with its root, tips, contact plants and reach targets in their colours; the report marks
come from the report document frame by frame."""

import numpy as np
import pytest
from matplotlib import image

import deik
from deik.cli.app import main
from deik.viz.clip_report import POSE_HEIGHT, clip_report_figure, most_changed_frame, plot_clip_report, pose_panel
from deik.viz.marks import COLOURS
from deik.viz.report_marks import marks_at


def _count(picture, kind, distance=0.06):
    return int((np.abs(picture - np.array(COLOURS[kind]) / 255).max(axis=-1) < distance).sum())


def _clips():
    """A 10-frame humanoid clip and its 'fix', which raises the left arm most in frame 6."""
    human = deik.humanoid()
    poses = np.tile(human.reference, (10, 1))
    original = deik.Clip.from_poses(human, poses, frame_time=1 / 30)
    raised = poses.copy()
    raised[:, human.dof_names.index("left_shoulder.Zrotation")] += np.where(np.arange(10) == 6, 1.2, 0.2)
    return original, deik.Clip.from_poses(human, raised, frame_time=1 / 30)


def _document(original):
    heel = deik.forward_kinematics(original.skeleton, original.pose(0)).position("left_heel")
    return {
        "frames": 10,
        "contacts": {
            "sites": [{"site": "left_heel", "contacts": [{"first_frame": 4, "last_frame": 8, "plant": list(heel)}]}]
        },
        "reach_targets": [{"site": "left_hand", "frames": [5, 6, 7], "targets": [[0.6, 1.6, 0.2]] * 3}],
    }


def test_the_most_changed_frame_and_its_marks():
    original, fixed = _clips()
    assert most_changed_frame(original, fixed) == 6
    document = _document(original)
    marks = marks_at(document, 6, 10)
    assert set(marks) == {"contact", "target"} and np.allclose(marks["target"], [[0.6, 1.6, 0.2]])
    assert {kind: len(points) for kind, points in marks_at(document, 2, 10).items()} == {"contact": 0, "target": 0}
    assert len(marks_at(document, 8, 10)["contact"]) == 1 and len(marks_at(document, 9, 10)["contact"]) == 0


@pytest.mark.parametrize("projection", ["2d", "3d"])
def test_the_pose_panel_draws_before_after_and_marks(tmp_path, projection):
    original, fixed = _clips()
    panel = pose_panel(original, fixed, _document(original), projection, "m")
    assert panel.frame == 6
    path = tmp_path / "report.png"
    series = {"error (mm)": (np.linspace(0, 1, 10), np.zeros(10))}
    plot_clip_report(series, path, 1 / 30, "test", pose=panel)
    picture = image.imread(path)[..., :3]
    top = picture[: int(POSE_HEIGHT * 100)]  # the panel (dpi 100), above the series and their grey 'before' lines
    for kind, least in (("compare", 50), ("bone", 100), ("root", 20), ("tip", 30), ("contact", 10), ("target", 10)):
        assert _count(top, kind) > least, kind
    plot_clip_report(series, tmp_path / "plain.png", 1 / 30, "test")
    assert _count(image.imread(tmp_path / "plain.png")[..., :3], "root") == 0


@pytest.mark.shared_data
def test_deik_clip_report_3d_draws_the_fixed_frame(tmp_path, shared_data):
    walk = shared_data / "humanoid" / "humanoid3d_walk.bvh"
    report = tmp_path / "report.png"
    argv = ["clip", str(walk), "--out", str(tmp_path / "fixed.bvh"), "--report", str(report), "--report-3d", "--quiet"]
    assert main(argv) == 0
    top = image.imread(report)[: int(POSE_HEIGHT * 100) + 150, :, :3]
    assert _count(top, "root") > 20 and _count(top, "bone") > 100 and _count(top, "contact") > 10


def test_report_3d_needs_report(tmp_path, capsys):
    assert main(["clip", "in.bvh", "--out", str(tmp_path / "o.bvh"), "--report-3d"]) == 2
    assert "--report-3d sets how --report draws the clip: add --report report.png" in capsys.readouterr().err


# the series and notes of `deik clip --report` on a walk with a reach: the longest names it draws
SERIES_NAMES = (
    "foot sliding (mm/frame)",
    "COM outside support (mm)",
    "ZMP outside support (soles included) (mm)",
    "penetration below the floor (mm)",
    "floating in contact (mm)",
    "joint angle from the capture (deg)",
    "joint position from the capture (mm)",
    "position acceleration (m/s^2)",
    "reach RightElbow_end distance (mm)",
    "sites in contact (count)",
)
NOTES = (
    "foot sliding max: 13.4 before, 0.00864 after (mm/frame)",
    "ZMP outside support (soles included) mean: 74.9 before, 113 after (mm)",
    "peaks against the capture's: dof velocity x1.00, dof acceleration x1.00, position velocity x1.04, "
    "position acceleration x1.07",
)


def _boxes(figure):
    """(the titles, axis labels and tip names drawn, each axes' y label), each as (text, window
    extent in display pixels)."""
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    containers = [figure, *figure.subfigs]
    texts = [c._suptitle for c in containers if c._suptitle is not None]  # matplotlib keeps no public handle
    for ax in figure.axes:
        axis_labels = [ax.xaxis.label, ax.yaxis.label] + ([ax.zaxis.label] if hasattr(ax, "zaxis") else [])
        # a 3-D axes places its texts only while drawing, so their extents cannot be read back
        texts += [ax.title, *axis_labels, *([] if hasattr(ax, "zaxis") else ax.texts)]
    labels = [ax.yaxis.label for ax in figure.axes if ax.get_ylabel()]
    return [(t.get_text(), t.get_window_extent(renderer)) for t in texts if t.get_text().strip()], [
        (t.get_text(), t.get_window_extent(renderer)) for t in labels
    ]


@pytest.mark.parametrize("projection", ["2d", "3d"])
def test_the_title_notes_and_series_names_stay_inside_the_picture_and_apart(projection):
    original, fixed = _clips()
    panel = pose_panel(original, fixed, _document(original), projection, "m")
    series = {name: (np.linspace(0, k + 1, 10), np.zeros(10)) for k, name in enumerate(SERIES_NAMES)}
    figure = clip_report_figure(series, 1 / 30, "deik clip humanoid3d_walk.bvh", NOTES, pose=panel)
    try:
        texts, labels = _boxes(figure)
        width, height = figure.bbox.width, figure.bbox.height
        outside = [text for text, box in texts if box.x0 < 0 or box.x1 > width or box.y0 < 0 or box.y1 > height]
        assert outside == []
        names = [label for label, _ in labels if label.replace("\n", " ") in SERIES_NAMES]
        assert len(names) == len(SERIES_NAMES)
        for k, (first, a) in enumerate(labels):
            for second, b in labels[k + 1 :]:
                assert not a.overlaps(b), (first, second)
    finally:
        import matplotlib.pyplot as plt

        plt.close(figure)
