"""The self-collision goal: the bone capsules of one skeleton stay apart (arms out of the torso,
legs out of each other). Bones, link distances and default radii come from
deik.model.capsules; the pairs it tests are data in the term table (TermRow.pairs)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from deik.errors import InputError
from deik.model.capsules import bone_starts, default_radii, link_distance
from deik.model.geometry import segments_distance
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goal_values import pack
from deik.objectives.goals import LENGTH_TOLERANCE, Goal
from deik.objectives.kinds import SELF_COLLISION
from deik.objectives.table import TermRow


def _radius(value, what: str) -> float:
    if not (isinstance(value, numbers.Real) and math.isfinite(value) and value >= 0):
        raise InputError(f"self collision: {what} must be a finite number >= 0 (length units), got {value!r}")
    return float(value)


@dataclass(frozen=True)
class SelfCollision(Goal):
    """Keep every bone's capsule out of the others'; error = summed penetration depth (length
    units) of the tested pairs closer than radius a + radius b + `margin`; met within its
    tolerance, by default LENGTH_TOLERANCE like every length goal (a float32 solve cannot tell
    a few nanometres of depth from none).

    A bone runs from a joint to a child joint or site, its capsule radius is its start joint's:
    `radii` None takes deik.model.capsules.default_radii (from the segment masses: a thigh is
    about 8 cm on the 1.75 m humanoid), a number sets every bone's, and a dict {joint name:
    radius} overrides the bones leaving those joints. Not tested: bones within `skip` links
    (1: those sharing a joint; the default 2 also skips bones joined through one short bone,
    such as an upper arm and the chest across the clavicle, whose capsules meet at any pose),
    and pairs whose capsules already overlap in the reference pose (the thigh and the belly)."""

    LABEL = "self collision"
    margin: float = 0.0
    radii: object = None
    skip: int = 2

    def joint_radii(self, skeleton: Skeleton) -> np.ndarray:
        """(J,) the capsule radius of the bones leaving each joint (length units)."""
        if self.radii is None:
            return default_radii(skeleton)
        if not isinstance(self.radii, dict):
            return np.full(skeleton.n_joints, _radius(self.radii, "radii"))
        radii = default_radii(skeleton)
        for name, value in self.radii.items():
            k = skeleton.frame_index(name)
            if k >= skeleton.n_joints:
                raise InputError(f"self collision: {name!r} is a site; radii go on joints (the bones leaving them)")
            radii[k] = _radius(value, f"radius of {name!r}")
        return radii

    def pairs(self, skeleton: Skeleton) -> tuple[tuple[int, int, float], ...]:
        """The tested bone pairs (bone a, bone b, radius a + radius b), bones named by their end
        frames (deik.model.capsules)."""
        if not (isinstance(self.skip, int) and self.skip >= 1):
            raise InputError(f"self collision: skip must be an integer >= 1 (links), got {self.skip!r}")
        start, radius = bone_starts(skeleton), self.joint_radii(skeleton)
        bone_radius = radius[np.maximum(start, 0)]
        a, b = np.triu_indices(skeleton.n_frames, 1)
        keep = (a > 0) & (link_distance(skeleton)[a, b] > self.skip)
        a, b = a[keep], b[keep]
        p = forward_kinematics(skeleton, skeleton.reference).p_world_frame
        rest = segments_distance(p[start[a]], p[a], p[start[b]], p[b])
        reach = bone_radius[a] + bone_radius[b]
        apart = rest > reach
        return tuple(zip(a[apart].tolist(), b[apart].tolist(), reach[apart].tolist()))

    def row(self, skeleton: Skeleton) -> TermRow:
        """The margin in column 0 and the tested pairs; scale: the reach."""
        margin = _radius(self.margin, "margin")
        pairs = self.pairs(skeleton)
        if not pairs:
            raise InputError(
                f"self collision: skeleton {skeleton.name!r} has no bone pair to test (every pair is within "
                f"{self.skip} links or overlaps in the reference pose); lower skip or the radii"
            )
        params = pack(np.full((1, 1), margin))
        return self._row(SELF_COLLISION, params, LENGTH_TOLERANCE, scale=skeleton.reach, pairs=pairs)
