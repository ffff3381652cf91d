"""PNG pictures of poses: the root, the tip and a site are drawn in their colours where forward
kinematics puts them, in the front and side views and in the 3-D perspective view; the axes
name their unit; perspective makes the nearer of two equal bones longer."""

import numpy as np
import pytest
from matplotlib import image
from mpl_toolkits.mplot3d import proj3d

import deik
from deik.cli.app import main
from deik.viz import plot
from deik.viz.marks import COLOURS
from helpers import random_poses


def _perspective_data(points):
    """Y up: the perspective view's (x, y, z) axes show world (x, -z, y), a right-handed frame with
    up vertical (the front view shows (x, y), the side view (z, y))."""
    return np.stack([points[:, 0], -points[:, 2], points[:, 1]], axis=1)


def marked_skeleton():
    """Y up: a root, a ball joint half a unit above it, an elbow; a marker site on the upper
    bone (a site, no tip) and an end site (the tip)."""
    joints = [
        deik.Joint("root", None, dofs=deik.euler("ZXY")),
        deik.Joint("chest", "root", (0, 0.5, 0), deik.euler("ZXY")),
        deik.Joint("elbow", "chest", (0.4, 0, 0), deik.hinge((0, 0, 1))),
    ]
    sites = [deik.Site("marker", "chest", (0.2, 0, 0)), deik.Site("hand", "elbow", (0.3, 0, 0))]
    return deik.build_skeleton(joints, sites=sites, name="marked")


def _display(ax, data):
    """Display pixels (N, 2) (origin bottom left) of data coordinates (N, 2) or (N, 3) on `ax`."""
    data = np.atleast_2d(data)
    if data.shape[1] == 3:
        x, y, _ = proj3d.proj_transform(*data.T, ax.get_proj())
        data = np.stack([x, y], axis=1)
    return ax.transData.transform(data)


def _near(picture, pixel, kind, radius=5):
    """How many pixels of `picture` (H, W, 3) within `radius` of display `pixel` have the colour of `kind`."""
    height = picture.shape[0]
    col, row = int(round(pixel[0])), int(round(height - pixel[1]))
    window = picture[max(row - radius, 0) : row + radius + 1, max(col - radius, 0) : col + radius + 1]
    return int((np.abs(window - np.array(COLOURS[kind]) / 255).max(axis=-1) < 0.06).sum())


def _picture(tmp_path, figure, name):
    path = tmp_path / name
    figure.savefig(path, format="png", dpi=100)  # as plot_pose saves it
    return image.imread(path)[..., :3]


@pytest.mark.parametrize("projection", ["2d", "3d"])
def test_root_tip_and_site_are_drawn_where_the_pose_puts_them(tmp_path, projection):
    sk = marked_skeleton()
    pose = random_poses(sk, 1, seed=7)[0] * 0.5
    points = deik.forward_kinematics(sk, pose).p_world_frame
    figure = plot.pose_figure(sk, pose, projection=projection, unit="m")
    figure.canvas.draw()
    if projection == "2d":
        views = [points[:, [0, 1]], points[:, [2, 1]]]
    else:
        views = [_perspective_data(points)]
    assert len(figure.axes) == len(views)
    expected = [_display(ax, data) for ax, data in zip(figure.axes, views)]
    picture = _picture(tmp_path, figure, "pose.png")
    root, marker, hand = (sk.frame_index(n) for n in ("root", "marker", "hand"))
    for pixels in expected:
        if np.linalg.norm(pixels[root] - pixels[hand]) < 20:
            continue  # the pose hides one behind the other in this view
        assert _near(picture, pixels[root], "root") > 20
        assert _near(picture, pixels[hand], "tip") > 20 and _near(picture, pixels[hand], "root") == 0
        assert _near(picture, pixels[marker], "site") > 3 and _near(picture, pixels[marker], "tip") == 0
        assert _near(picture, pixels[root], "tip") == 0


def test_axes_name_their_unit_and_the_views_directions():
    figure = plot.pose_figure(marked_skeleton(), np.zeros(7), projection="2d", unit="cm")
    assert [(ax.get_xlabel(), ax.get_ylabel()) for ax in figure.axes] == [("x (cm)", "y (cm)"), ("z (cm)", "y (cm)")]
    figure = plot.pose_figure(marked_skeleton(), np.zeros(7), projection="3d")
    (ax,) = figure.axes
    labels = (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel())
    assert labels == ("x (length units)", "-z (length units)", "y (length units)")


def test_perspective_draws_the_nearer_of_two_equal_bones_longer():
    """Two equal horizontal bones, one in front of the other: the 3-D view's perspective makes the
    nearer one longer on the picture; the front view (orthographic) draws them alike."""
    joints = [
        deik.Joint("root", None, dofs=deik.hinge((0, 1, 0))),
        deik.Joint("near", "root", (0, 1, 1)),
        deik.Joint("far", "root", (0, 1, -1)),
    ]
    sites = [deik.Site("near_end", "near", (1, 0, 0)), deik.Site("far_end", "far", (1, 0, 0))]
    sk = deik.build_skeleton(joints, sites=sites)
    points = deik.forward_kinematics(sk, np.zeros(1)).p_world_frame
    lengths = {}
    for projection, to_data in (("3d", _perspective_data), ("2d", lambda p: p[:, :2])):
        figure = plot.pose_figure(sk, np.zeros(1), projection=projection)
        figure.canvas.draw()
        pixels = _display(figure.axes[0], to_data(points))
        near = np.linalg.norm(pixels[sk.frame_index("near_end")] - pixels[sk.frame_index("near")])
        far = np.linalg.norm(pixels[sk.frame_index("far_end")] - pixels[sk.frame_index("far")])
        lengths[projection] = near / far
    assert lengths["3d"] > 1.05 and lengths["2d"] == pytest.approx(1.0)


def test_solve_plot_3d_draws_the_root_and_marks_the_target(tmp_path):
    png = tmp_path / "pose.png"
    argv = ["solve", "chain3d:3", "--reach", "tip", "1.5", "1", "1", "--population", "24", "--generations", "40"]
    assert main([*argv, "--seed", "0", "--plot", str(png), "--plot-3d"]) == 0
    picture = image.imread(png)[..., :3]
    for kind in ("root", "tip", "target", "bone"):
        assert (np.abs(picture - np.array(COLOURS[kind]) / 255).max(axis=-1) < 0.06).sum() > 30, kind


def test_plot_3d_needs_plot(tmp_path, capsys):
    assert main(["solve", "chain:3", "--reach", "tip", "1", "1", "0", "--plot-3d"]) == 2
    assert "--plot-3d sets how --plot draws the pose: add --plot pose.png" in capsys.readouterr().err


def test_left_and_right_limbs_have_colours_of_their_own(tmp_path):
    """The humanoid's shins and forearms, drawn front on: each bone's middle in its side's colour
    (left red, right green, viz.marks.COLOURS) and not in the other side's; the spine in the
    middle's colour."""
    human = deik.humanoid()
    points = deik.forward_kinematics(human, human.reference).p_world_frame
    figure = plot.pose_figure(human, human.reference, projection="2d", unit="m")
    figure.canvas.draw()
    front = figure.axes[0]
    picture = _picture(tmp_path, figure, "human.png")
    bones = {
        "left": [("left_knee", "left_ankle"), ("left_elbow", "left_wrist")],
        "right": [("right_knee", "right_ankle"), ("right_elbow", "right_wrist")],
        "bone": [("spine", "chest")],
    }
    for side, pairs in bones.items():
        for parent, child in pairs:
            middle = (points[human.frame_index(parent)] + points[human.frame_index(child)]) / 2
            pixel = _display(front, middle[[0, 1]])[0]
            assert _near(picture, pixel, side, radius=3) > 3, (side, parent, child)
            others = {"left", "right", "bone"} - {side}
            assert all(_near(picture, pixel, other, radius=3) == 0 for other in others), (side, parent, child)
