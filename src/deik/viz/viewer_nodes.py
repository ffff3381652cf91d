"""The 3-D nodes of a Scene in a viser server: bones as lines coloured by side, the body's solids
(viz.body_shapes) around them, joints, sites, the root and the tips as points in their viz.marks
colours, the tips' and root's names and frame axes, the centre of mass, marks, obstacles, a
compared figure in grey, and a floor grid whose cell size the panel states. The camera opens on
the body of the first step, which fills FILL of the view's height; marks and axes are sized to
the body. `SceneNodes.show(step)` moves every node to one step of the scene.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from deik.model.orientations import quaternion_matrix
from deik.viz.body_shapes import body_height
from deik.viz.marks import COLOURS, bone_sides, bones, roots, spread_out, tips
from deik.viz.plot import view_axes
from deik.viz.scene import Figure, Scene

if TYPE_CHECKING:  # viser is imported by viz.viewer, when a view is served
    from viser import ViserServer

BONE_PIXELS = 5.0  # bone lines keep this width on screen at any zoom
# Frame axes start shown on a figure with this few tips (a robot arm, whose tool frame's
# orientation matters); a character's many end sites would hide under theirs.
AXES_TIPS = 2
FOV = math.radians(50)  # the camera's vertical field of view
FILL = 0.85  # of the view's height the body's bounding sphere fills on opening
BODY_OPACITY = 0.6  # the solids let the bones, joints and marks inside them show through


def nice_step(length: float) -> float:
    """The 1, 2 or 5 x 10^k nearest below `length` (> 0): a grid cell people can read."""
    power = 10.0 ** math.floor(math.log10(length))
    return max(m * power for m in (1.0, 2.0, 5.0) if m * power <= length)


def turn_z_to(up: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) that turns +Z onto the unit vector `up` (viser's grid lies in XY)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, up)
    if np.linalg.norm(axis) < 1e-9:
        return np.array([1.0, 0.0, 0.0, 0.0]) if up[2] > 0 else np.array([0.0, 1.0, 0.0, 0.0])
    angle = math.acos(float(np.clip(z @ up, -1.0, 1.0)))
    axis /= np.linalg.norm(axis)
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) * axis)])


class SceneNodes:
    """Every node of `scene` in `server` (a viser.ViserServer), shown at step 0."""

    def __init__(self, server: ViserServer, scene: Scene):
        self.server, self.scene = server, scene
        low, high = scene.bounds()
        self.size = max(float((high - low).max()), 1e-6)
        self.centre = (low + high) / 2
        self.up = np.asarray(scene.up, float) / np.linalg.norm(scene.up)
        self.cell = nice_step(self.size / 8)
        self.body = body_height(scene.figure)  # marks and axes follow the body, not the path it walks
        self.point = self.body / 80  # joint marker size, length units
        api = server.scene
        api.set_up_direction(tuple(self.up))
        self._grid(api, low, high)
        # the compared figure first, so that where the two coincide the viewed one is drawn over it
        self.compare = None if scene.compare is None else self._figure_nodes(api, "/compare", scene.compare, "compare")
        self.figure = self._figure_nodes(api, "/figure", scene.figure, "bone")
        self.solids = self._solids(api, scene)
        self.marks = [
            api.add_point_cloud(
                f"/marks/{m.kind}_{k}",
                np.zeros((1, 3)),
                COLOURS[m.kind],
                point_size=2.2 * self.point,
                point_shape="diamond" if m.kind == "target" else "square",
                point_shading="flat",
            )
            for k, m in enumerate(scene.marks)
        ]
        self.obstacles = [
            api.add_icosphere(f"/obstacles/{k}", radius=radius, color=COLOURS["obstacle"], opacity=0.35)
            for k, (_, radius) in enumerate(scene.obstacles)
        ]
        self._camera(server)
        self.show(0)

    def _grid(self, api, low: np.ndarray, high: np.ndarray) -> None:
        """A floor grid under everything, or at the scene's floor height, across the figure."""
        heights = self.scene.figure.positions.reshape(-1, 3) @ self.up
        floor = self.scene.floor if self.scene.floor is not None else float(heights.min())
        middle = self.centre - (self.centre @ self.up) * self.up + floor * self.up
        width = 2 * self.size
        api.add_grid(
            "/grid",
            width=width,
            height=width,
            cell_size=self.cell,
            section_size=5 * self.cell,
            wxyz=tuple(turn_z_to(self.up)),
            position=tuple(middle),
        )

    def _figure_nodes(self, api, root: str, figure: Figure, kind: str) -> dict:
        """Nodes of one figure: bone lines, and for the main figure its joints, sites, root, tips,
        their names and frame axes, and the centre of mass."""
        step0 = figure.positions[0]
        pairs = bones(figure.parents)
        sides = np.array(bone_sides(figure.parents, figure.names) if kind == "bone" else [kind] * len(pairs))
        # one node per colour: a colour per vertex would be drawn lighter (taken as linear, not sRGB)
        nodes = {
            "bones": [
                (
                    pairs[sides == side],
                    api.add_line_segments(
                        f"{root}/bones_{side}",
                        step0[pairs[sides == side]],
                        COLOURS[side],
                        thickness=BONE_PIXELS,
                        thickness_units="screen",
                    ),
                )
                for side in dict.fromkeys(sides)
            ],
        }
        if kind != "bone":
            return nodes
        ends = tips(figure.parents, step0)
        named = np.array(spread_out(step0, np.concatenate([roots(figure.parents), ends])))
        self.axes_shown = len(ends) <= AXES_TIPS
        groups = {
            "joint": np.arange(figure.n_joints),
            "site": np.arange(figure.n_joints, len(figure.names)),
            "root": roots(figure.parents),
            "tip": ends,
        }
        sizes = {"joint": 1.0, "site": 0.8, "root": 2.2, "tip": 1.8}
        nodes["groups"] = {}
        for name, index in groups.items():
            if len(index):
                cloud = api.add_point_cloud(
                    f"{root}/{name}s",
                    step0[index],
                    COLOURS[name],
                    point_size=sizes[name] * self.point,
                    point_shape="diamond" if name == "site" else "circle",
                    point_shading="flat",
                )
                nodes["groups"][name] = (index, cloud)
        nodes["named"] = named
        nodes["labels"] = [api.add_label(f"{root}/names/{figure.names[k]}", figure.names[k]) for k in named]
        nodes["axes"] = api.add_batched_axes(
            f"{root}/axes",
            batched_wxyzs=figure.quaternions_wxyz[0][named],
            batched_positions=step0[named],
            axes_length=self.body / 8,
            axes_radius=self.body / 200,
            visible=self.axes_shown,
        )
        if figure.com is not None:
            nodes["com"] = api.add_point_cloud(
                f"{root}/com",
                figure.com[:1],
                COLOURS["centre of mass"],
                point_size=2.5 * self.point,
                point_shape="circle",
                point_shading="flat",
            )
        return nodes

    def _solids(self, api, scene: Scene) -> dict:
        """{frame index: its node}: a frame node per frame that carries solids, the solids'
        meshes under it (so that moving the frame moves them)."""
        nodes = {}
        figure = scene.figure
        for k, shape in enumerate(scene.shapes):
            frame = shape.frame
            if frame not in nodes:
                nodes[frame] = api.add_frame(
                    f"/figure/body/{frame}",  # by index: a link name may hold a "/"
                    show_axes=False,
                    wxyz=tuple(figure.quaternions_wxyz[0, frame]),
                    position=tuple(figure.positions[0, frame]),
                )
            api.add_mesh_simple(
                f"/figure/body/{frame}/{k}",
                shape.vertices,
                shape.faces,
                color=shape.colour,
                opacity=BODY_OPACITY,
                cast_shadow=False,  # shadows of many solids slow a browser without a GPU down to a crawl
                receive_shadow=False,
            )
        return nodes

    def _camera(self, server) -> None:
        """Start looking at the first step's body from the front, a little above, from where its
        bounding sphere (solids included) fills FILL of the view's height."""
        across, depth, up = view_axes(self.up)
        direction = 0.45 * across - 0.85 * depth + 0.3 * up
        figure = self.scene.figure
        points = [figure.positions[0]]
        for shape in self.scene.shapes:
            R = quaternion_matrix(figure.quaternions_wxyz[0, shape.frame], "wxyz")
            points.append(shape.vertices @ R.T + figure.positions[0, shape.frame])
        points = np.concatenate(points)
        low, high = points.min(axis=0), points.max(axis=0)
        radius = max(float(np.linalg.norm(high - low)) / 2, 1e-6)
        distance = radius / (FILL * math.tan(FOV / 2))
        server.initial_camera.fov = FOV
        server.initial_camera.look_at = tuple((low + high) / 2)
        server.initial_camera.position = tuple((low + high) / 2 + distance * direction / np.linalg.norm(direction))

    def show(self, step: int) -> None:
        """Move every node to `step` of the scene."""
        with self.server.atomic():
            self._move(self.figure, self.scene.figure, step)
            if self.compare is not None:
                self._move(self.compare, self.scene.compare, step)
            for node, marks in zip(self.marks, self.scene.marks):
                points = marks.points[step]
                present = points[np.isfinite(points).all(axis=1)]
                node.visible = len(present) > 0
                if len(present):
                    node.points = present
            for node, (centre, _) in zip(self.obstacles, self.scene.obstacles):
                node.position = tuple(centre[step])

    def _move(self, nodes: dict, figure: Figure, step: int) -> None:
        points = figure.positions[step]
        if figure is self.scene.figure:
            for frame, node in self.solids.items():
                node.wxyz, node.position = figure.quaternions_wxyz[step, frame], points[frame]
        for pairs, line in nodes["bones"]:
            line.points = points[pairs]
        for index, cloud in nodes.get("groups", {}).values():
            cloud.points = points[index]
        for label, k in zip(nodes.get("labels", ()), nodes.get("named", ())):
            label.position = tuple(points[k])
        if "axes" in nodes:
            nodes["axes"].batched_positions = points[nodes["named"]]
            nodes["axes"].batched_wxyzs = figure.quaternions_wxyz[step][nodes["named"]]
        if "com" in nodes:
            nodes["com"].points = figure.com[step : step + 1]

    def show_body(self, visible: bool) -> None:
        for node in self.solids.values():
            node.visible = visible

    def show_names(self, visible: bool) -> None:
        for label in self.figure.get("labels", ()):
            label.visible = visible

    def show_axes(self, visible: bool) -> None:
        self.figure["axes"].visible = visible

    def show_compare(self, visible: bool) -> None:
        if self.compare is not None:
            for _, line in self.compare["bones"]:
                line.visible = visible
