"""BVH motion files: `read_bvh`/`parse_bvh` into a Clip, `write_bvh`/`format_bvh` back out.

The work is split by job: parse.py (reading), hierarchy.py (the HIERARCHY block), write.py,
preview.py (a BVH of any skeleton's motion); the Clip is deik.io.motion. docs/formats.md says what is read.
"""

from deik.io.bvh.parse import parse_bvh, read_bvh
from deik.io.bvh.write import format_bvh, write_bvh
from deik.io.motion import Clip, JointChannels

__all__ = ["Clip", "JointChannels", "format_bvh", "parse_bvh", "read_bvh", "write_bvh"]
