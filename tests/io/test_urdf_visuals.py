"""A URDF robot's looks (deik.io.urdf.visuals): every geometry kind with its origin, scale and
colour (inline or named), mesh files found through package://, relative and file:// names, a
missing one reported as None, and malformed visuals refused with their line."""

import os

import numpy as np
import pytest

from deik.errors import FileFormatError
from deik.io.urdf.visuals import read_visuals, resolve_mesh

ROBOT = """<robot name="shapes">
  <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
  <link name="a">
    <visual><origin xyz="0 0 0.1" rpy="0 1.5 0"/><geometry><box size="0.1 0.2 0.3"/></geometry>
      <material name="grey"/></visual>
    <visual><geometry><cylinder radius="0.05" length="0.4"/></geometry>
      <material name="red"><color rgba="1 0 0 1"/></material></visual>
  </link>
  <link name="b">
    <visual><geometry><sphere radius="0.07"/></geometry></visual>
    <visual><geometry><capsule radius="0.02" length="0.2"/></geometry></visual>
    <visual><geometry><mesh filename="package://robot_description/meshes/b.stl" scale="0.001 0.001 0.001"/>
      </geometry></visual>
  </link>
  <link name="c"/>
</robot>
"""


def _write(folder, text, name="robot.urdf"):
    path = folder / name
    path.write_text(text)
    return path


def test_every_geometry_kind_with_its_origin_scale_and_colour(tmp_path):
    (tmp_path / "robot_description" / "meshes").mkdir(parents=True)
    (tmp_path / "robot_description" / "meshes" / "b.stl").write_text("solid b\nendsolid b\n")
    urdf = tmp_path / "robot_description" / "urdf"
    urdf.mkdir()
    visuals = read_visuals(_write(urdf, ROBOT))
    assert list(visuals) == ["a", "b"]  # c has none
    box, cylinder = visuals["a"]
    assert box.kind == "box" and box.size == (0.1, 0.2, 0.3) and box.rgba == (0.5, 0.5, 0.5, 1)
    assert np.allclose(box.xyz, [0, 0, 0.1]) and np.allclose(box.rpy, [0, 1.5, 0])
    assert cylinder.kind == "cylinder" and cylinder.size == (0.05, 0.4) and cylinder.rgba == (1, 0, 0, 1)
    sphere, capsule, mesh = visuals["b"]
    assert (sphere.kind, sphere.size, sphere.rgba) == ("sphere", (0.07,), None)
    assert (capsule.kind, capsule.size) == ("capsule", (0.02, 0.2))
    assert mesh.kind == "mesh" and mesh.size == (0.001,) * 3
    assert mesh.path == tmp_path / "robot_description" / "meshes" / "b.stl"  # found above the URDF's folder


def test_mesh_names_resolve_to_files_or_to_none(tmp_path, monkeypatch):
    (tmp_path / "urdf").mkdir()
    (tmp_path / "urdf" / "here.obj").write_text("")
    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes" / "a.dae").write_text("")
    folder = tmp_path / "urdf"
    assert resolve_mesh("here.obj", folder) == folder / "here.obj"
    assert resolve_mesh(f"file://{tmp_path}/pkg/meshes/a.dae", folder) == tmp_path / "pkg" / "meshes" / "a.dae"
    assert resolve_mesh("package://pkg/meshes/a.dae", folder) == tmp_path / "pkg" / "meshes" / "a.dae"
    assert resolve_mesh("package://pkg/meshes/gone.dae", folder) is None
    assert resolve_mesh("package://other/a.dae", folder) is None
    elsewhere = tmp_path / "ros" / "other"
    elsewhere.mkdir(parents=True)
    (elsewhere / "a.dae").write_text("")
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join(["/nonexistent", str(tmp_path / "ros")]))
    assert resolve_mesh("package://other/a.dae", folder) == elsewhere / "a.dae"


@pytest.mark.parametrize(
    "visual, message",
    [
        ('<box size="0.1 0.2"/>', r'<box size="0.1 0.2"> holds 2 numbers; write 3 numbers'),
        ('<sphere radius="-1"/>', r"<sphere> needs positive radius"),
        ('<cylinder radius="0.1"/>', r"<cylinder> needs positive radius and length"),
        ('<cone radius="0.1"/>', r"<cone> is not a URDF geometry"),
        ("<mesh/>", r'<mesh> needs filename="..."'),
    ],
)
def test_a_malformed_visual_is_refused_with_its_line(tmp_path, visual, message):
    text = f'<robot name="r">\n<link name="a">\n<visual><geometry>\n{visual}\n</geometry></visual>\n</link>\n</robot>\n'
    with pytest.raises(FileFormatError, match=message) as error:
        read_visuals(_write(tmp_path, text))
    assert str(error.value).startswith(f"{tmp_path / 'robot.urdf'}:4: link 'a': ")  # the geometry's line
