"""Files in and out: BVH clips, URDF robots, segment tables, joint limits, atomic writes, and a
skeleton described as data (describe.py)."""
