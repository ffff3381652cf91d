"""URDF robots in: `read_urdf(path, base=None, tip=None) -> Skeleton` and its joints'
velocity limits `read_velocity_limits(path)` (robot.py), on our own safe
XML reader (safe_xml.py), the link tree (tree.py) and checked `<link>`/`<joint>` elements
(elements.py); what they look like, for the 3-D view only: `read_visuals` (visuals.py)."""

from deik.io.urdf.robot import read_urdf, read_velocity_limits

__all__ = ["read_urdf", "read_velocity_limits"]
