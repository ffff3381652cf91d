"""Retargeting: a clip onto other proportions or another skeleton (docs/retarget.md).

Layer between clips and viz: it reuses the clip machinery (contacts, the clip fix, metrics)
and io (BVH, URDF, trajectories)."""
