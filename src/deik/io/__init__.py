"""Files in and out: BVH clips, URDF robots, segment tables, and atomic writes."""
