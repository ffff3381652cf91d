"""Goals a user asks for, each compiled to one row of the term table.

Targets may carry a leading batch axis (B, ...) to pose B problems at once. Weights lie in
[-1, 1] (Eq. 2); `level` sets strict priority (0 highest; a lower level never buys a higher
one's error beyond its tolerance); `tolerance` is in metres / radians and decides convergence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from deik.objectives import table as tt
from deik.model.skeleton import Skeleton


def _vector(value, shape: tuple[int, ...], what: str) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape[-len(shape):] != shape or a.ndim > len(shape) + 1:
        raise ValueError(f"{what} must have shape {shape} or (batch, *{shape}), got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{what} contains NaN or infinite values: {value!r}")
    return a.reshape((-1,) + shape) if a.ndim > len(shape) else a[None]


@dataclass(frozen=True)
class Goal:
    """Shared settings: weight in [-1, 1], mu > 0, level >= 0, tolerance >= 0 or None."""

    weight: float = field(default=1.0, kw_only=True)
    mu: float = field(default=1.0, kw_only=True)
    level: int = field(default=0, kw_only=True)
    tolerance: float | None = field(default=None, kw_only=True)
    active: object = field(default=None, kw_only=True)

    def gain(self) -> np.ndarray:
        """Per-problem weight multiplier (B,) or (1,): 1 where the goal applies, 0 where `active`
        (a bool per problem of a batch, e.g. the frames of a contact) switches it off."""
        if self.active is None:
            return np.ones(1)
        active = np.asarray(self.active)
        if active.dtype != np.bool_ or active.ndim != 1 or active.size == 0:
            raise ValueError(f"active must be a non-empty 1-D bool array (one per problem), got {self.active!r}")
        return active.astype(np.float64)

    def _check_settings(self, label: str) -> None:
        if not (-1.0 <= self.weight <= 1.0):
            raise ValueError(f"{label}: weight {self.weight!r} must lie in [-1, 1] (Eq. 2)")
        if not (self.mu > 0 and math.isfinite(self.mu)):
            raise ValueError(f"{label}: mu {self.mu!r} must be a positive finite number")
        if not (isinstance(self.level, int) and self.level >= 0):
            raise ValueError(f"{label}: level {self.level!r} must be an integer >= 0")
        if self.tolerance is not None and not (self.tolerance >= 0 and math.isfinite(self.tolerance)):
            raise ValueError(f"{label}: tolerance {self.tolerance!r} must be >= 0 (metres or radians)")

    def _row(self, kind, label, frames=(), scale=1.0, default_tol=-1.0, dof_weight=None):
        self._check_settings(label)
        tol = default_tol if self.tolerance is None else float(self.tolerance)
        return tt.TermRow(kind, label, tuple(frames), (), float(self.weight), float(self.mu),
                          float(scale), tol, self.level, dof_weight)

    def params(self, skeleton: Skeleton) -> np.ndarray:
        """Per-problem parameters (B, N_PARAMS); B = 1 when the goal has no batch axis."""
        return np.zeros((1, tt.N_PARAMS))


def _pack(*parts: np.ndarray) -> np.ndarray:
    """Concatenate parts (B_k, ...) along their flattened trailing axes -> (B, N_PARAMS);
    only the leading batch axis broadcasts."""
    B = max(p.shape[0] for p in parts)
    out = np.zeros((B, tt.N_PARAMS))
    column = 0
    for p in parts:
        width = p[0].size
        out[:, column:column + width] = p.reshape(p.shape[0], width)  # a batch of 1 broadcasts
        column += width
    return out


def _check_reachable(skeleton: Skeleton, target: np.ndarray, frame: int | None, label: str):
    """Raise when a target lies farther from every possible root position than the reach."""
    length = skeleton.path_length(frame) if frame is not None else skeleton.reach
    gap = np.linalg.norm(target - np.clip(target, *skeleton.root_box()), axis=-1)
    worst = int(np.argmax(gap))
    if gap[worst] > length * (1 + 1e-9):
        raise ValueError(
            f"{label}: target {target[worst].round(6).tolist()} is unreachable: it lies "
            f"{gap[worst]:.6g} from the root's range but the chain to it is only {length:.6g} long"
        )


@dataclass(frozen=True)
class Position(Goal):
    """Place joint or site `frame` at `target` (3,) (Eq. 5). Default tolerance: 1 % of reach."""

    frame: str
    target: object

    def row(self, skeleton: Skeleton) -> tt.TermRow:
        f = skeleton.frame_index(self.frame)
        _check_reachable(skeleton, _vector(self.target, (3,), f"{self.frame} target"), f, f"position {self.frame}")
        return self._row(tt.POSITION, f"position {self.frame}", (f,), skeleton.reach, 0.01 * skeleton.reach)

    def params(self, skeleton):
        return _pack(_vector(self.target, (3,), f"{self.frame} target"))


@dataclass(frozen=True)
class Orientation(Goal):
    """Turn `frame` to world rotation `target` (3, 3); error = angle between rotations (rad)."""

    frame: str
    target: object

    def row(self, skeleton):
        R = _vector(self.target, (3, 3), f"{self.frame} orientation")
        eye = np.eye(3)
        # R R^T = I within 1e-5 (2e-5 on the diagonal, as np.allclose), and no reflection
        if not (np.abs(R @ np.swapaxes(R, -1, -2) - eye) <= 1e-5 * (1 + eye)).all() or (np.linalg.det(R) < 0).any():
            raise ValueError(f"orientation target for {self.frame!r} is not a rotation matrix")
        return self._row(tt.ORIENTATION, f"orientation {self.frame}", (skeleton.frame_index(self.frame),),
                         1.0, 0.01)

    def params(self, skeleton):
        return _pack(_vector(self.target, (3, 3), f"{self.frame} orientation"))


@dataclass(frozen=True)
class Aim(Goal):
    """Point `frame`'s local `axis` (3,) at world point `target` (3,); error in radians."""

    frame: str
    target: object
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def row(self, skeleton):
        if not np.linalg.norm(self.axis) > 0:
            raise ValueError(f"aim axis for {self.frame!r} must be non-zero")
        return self._row(tt.AIM, f"aim {self.frame}", (skeleton.frame_index(self.frame),), 1.0, 0.01)

    def params(self, skeleton):
        axis = np.asarray(self.axis, float)
        if axis.shape != (3,) or not np.linalg.norm(axis) > 0:
            raise ValueError(f"aim axis for {self.frame!r} must be non-zero (a 3-vector), got {self.axis!r}")
        return _pack((axis / np.linalg.norm(axis))[None], _vector(self.target, (3,), "aim target"))


@dataclass(frozen=True)
class CentreOfMass(Goal):
    """Bring the whole-body centre of mass to `target` (3,) (Eqs. 3, 4)."""

    target: object

    def row(self, skeleton):
        _need_mass(skeleton, "centre_of_mass")
        _check_reachable(skeleton, _vector(self.target, (3,), "centre-of-mass target"), None, "centre of mass")
        return self._row(tt.COM, "centre of mass", (), skeleton.reach, 0.01 * skeleton.reach)

    def params(self, skeleton):
        return _pack(_vector(self.target, (3,), "centre-of-mass target"))


@dataclass(frozen=True)
class ComOverSupport(Goal):
    """Keep the centre of mass's ground projection over `point` (3,): horizontal distance."""

    point: object

    def row(self, skeleton):
        _need_mass(skeleton, "com_over_support")
        return self._row(tt.COM_GROUND, "com over support", (), skeleton.reach, 0.01 * skeleton.reach)

    def params(self, skeleton):
        return _pack(_vector(self.point, (3,), "support point"))


@dataclass(frozen=True)
class ComInPolygon(Goal):
    """Keep the centre of mass's ground projection inside the convex hull of `frames`' ground
    projections (e.g. heel and toe sites of the standing feet); error = distance outside."""

    frames: tuple[str, ...]

    def row(self, skeleton):
        _need_mass(skeleton, "com_in_polygon")
        if not 1 <= len(self.frames) <= tt.MAX_TERM_FRAMES:
            raise ValueError(f"support polygon needs 1 to {tt.MAX_TERM_FRAMES} frames, got {len(self.frames)}")
        idx = tuple(skeleton.frame_index(f) for f in self.frames)
        return self._row(tt.SUPPORT_POLYGON, "com in support polygon", idx, skeleton.reach, 0.0)


@dataclass(frozen=True)
class Comfort(Goal):
    """Stay near a reference pose: sum (Eq. 6) or max (Eq. 7) of weighted |angle - reference|.

    `joint_weights`: None (all 1), "start" / "end" (linear ramp keeping the chain straight near
    its start or end, Fig. 2b/2c), a dict {joint name: weight} or an array (D,).
    `reference`: pose (D,) or (B, D); default the skeleton's reference pose.
    """

    mode: str = "sum"
    joint_weights: object = None
    reference: object = None
    mu: float = field(default=0.1, kw_only=True)

    def row(self, skeleton):
        if self.mode not in ("sum", "max"):
            raise ValueError(f"comfort mode must be 'sum' or 'max', got {self.mode!r}")
        kind = tt.COMFORT_SUM if self.mode == "sum" else tt.COMFORT_MAX
        return self._row(kind, f"comfort ({self.mode})", (), 1.0, -1.0, _dof_weights(skeleton, self.joint_weights))

    def reference_pose(self, skeleton) -> np.ndarray | None:
        if self.reference is None:
            return None
        return _vector(self.reference, (skeleton.n_dofs,), "comfort reference")


@dataclass(frozen=True)
class Obstacle(Goal):
    """A sphere (`centre` (3,), `radius`) that every bone, a capsule of `bone_radius`, must
    stay out of; error = summed penetration depth (length units), met at 0."""

    centre: object
    radius: float
    bone_radius: float = 0.0

    def row(self, skeleton):
        if not (self.radius > 0 and self.bone_radius >= 0):
            raise ValueError(f"obstacle radius must be > 0 and bone_radius >= 0, got {self.radius}, {self.bone_radius}")
        return self._row(tt.OBSTACLE, "obstacle", (), skeleton.reach, 0.0)

    def params(self, skeleton):
        centre = _vector(self.centre, (3,), "obstacle centre")
        return _pack(centre, np.full((1, 1), self.radius), np.full((1, 1), self.bone_radius))


def _need_mass(skeleton: Skeleton, what: str) -> None:
    if skeleton.total_mass <= 0:
        raise ValueError(f"{what} needs masses, but skeleton {skeleton.name!r} has none")


def _dof_weights(skeleton: Skeleton, spec) -> np.ndarray:
    D = skeleton.n_dofs
    if spec is None:
        return np.ones(D)
    if isinstance(spec, str):
        if spec not in ("start", "end"):
            raise ValueError(f"joint_weights string must be 'start' or 'end', got {spec!r}")
        depth = skeleton.dof_joint / max(skeleton.n_joints - 1, 1)
        return 1.0 - depth if spec == "start" else depth
    if isinstance(spec, dict):
        w = np.zeros(D)
        for name, value in spec.items():
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"joint_weights[{name!r}] = {value!r} must be finite and >= 0")
            w[skeleton.joint_dofs(name)] = value
        return w
    w = np.asarray(spec, dtype=np.float64)
    if w.shape != (D,) or not np.isfinite(w).all() or (w < 0).any():
        raise ValueError(f"joint_weights array must be ({D},), finite and >= 0, got shape {w.shape}")
    return w
