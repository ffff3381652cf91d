"""BVH motion files: `read_bvh`/`parse_bvh` into a Clip, `write_bvh`/`format_bvh` back out.

The work is split by job: bvh_read (parsing), bvh_write (writing), clip (the Clip and its
channel layout), segments (segment masses). docs/formats.md describes what is read and how.
"""

from deik.io.bvh_read import parse_bvh, read_bvh
from deik.io.bvh_write import format_bvh, write_bvh
from deik.io.clip import Clip, JointChannels

__all__ = ["Clip", "JointChannels", "format_bvh", "parse_bvh", "read_bvh", "write_bvh"]
