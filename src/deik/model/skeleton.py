"""The Skeleton: a frozen tree of joints, their degrees of freedom, sites and masses as arrays.

Joints are in topological order (parent index < child index, root -1). Frames are the joints
followed by the sites: frame f < n_joints is joint f, otherwise site f - n_joints. Built with
`deik.model.build.build_skeleton` or a builder (`chain`, `humanoid`); validated on construction.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError, UnknownNameError
from deik.model.joints import ROTATE, TRANSLATE
from deik.model.values import real_array
from deik.suggest import did_you_mean

MAX_LIMIT = 1e6  # radians or length units: beyond it float32 poses cannot resolve a millimetre or a degree
MAX_LENGTH = MAX_LIMIT  # length units: offsets of joints, sites and masses, mimic offsets, for the same reason
MAX_MASS = 1e12  # kg per segment: keeps every total finite
MAX_MIMIC_SCALE = 1e6  # a mimic's multiplier: a larger one turns a float32 step of its source into a leap


def _improper(R: np.ndarray) -> np.ndarray:
    """Indices of the matrices in R (N, 3, 3) that are not proper rotations (R R^T = I within
    1e-6, determinant +1, finite), checked all at once."""
    finite = np.isfinite(R).all(axis=(1, 2))
    safe = np.where(finite[:, None, None], R, 0.0)
    orthonormal = np.all(np.abs(safe @ np.swapaxes(safe, 1, 2) - np.eye(3)) <= 1e-6 + 1e-5 * np.eye(3), axis=(1, 2))
    return np.flatnonzero(~(finite & orthonormal & (np.linalg.det(safe) > 0)))


def _fail(message: str) -> None:
    raise InputError(message)


@dataclass(frozen=True, eq=False)
class Skeleton:
    """Arrays read by forward kinematics and the kernels. J joints, D DOFs, S sites, M masses.

    parents (J,) int32; offsets (J, 3) joint origin in parent frame; joint_dof_start (J+1,)
    CSR pointer into the DOF arrays; dof_joint (D,), dof_kind (D,) ROTATE/TRANSLATE,
    dof_axis (D, 3) in the joint frame; lower/upper/reference (D,) radians or length units;
    site_joint (S,), site_offset (S, 3), site_rotation (S, 3, 3); mass_joint (M,),
    mass_offset (M, 3) in the joint frame, mass_value (M,) kg; up (3,) world up direction;
    joint_rotation (J, 3, 3) fixed rotation of each joint's rest frame in its parent (identity
    by default). K mimic DOFs (not variables; applied after their joint's free DOFs), value =
    mimic_scale * q[mimic_source] + mimic_bias: mimic_names, mimic_joint (K,), mimic_kind (K,),
    mimic_axis (K, 3), mimic_source (K,) DOF index, mimic_scale (K,), mimic_bias (K,).
    joint_labels (J,): the names poses are keyed by (angles_by_joint, joint_dofs, Comfort's
    joint_weights): the joint names, except for a URDF robot, whose skeleton joints are its
    links (the frames goals name) and whose labels are the URDF joints that move them.
    helpers (J,) bool: joints that are no part of the body although they hang from its root (a
    game rig's IK target bones, which a clip never moves: deik.model.capsules.helper_joints);
    all False by default.
    """

    name: str
    joint_names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    joint_dof_start: np.ndarray
    dof_names: tuple[str, ...]
    dof_joint: np.ndarray
    dof_kind: np.ndarray
    dof_axis: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    reference: np.ndarray
    site_names: tuple[str, ...]
    site_joint: np.ndarray
    site_offset: np.ndarray
    site_rotation: np.ndarray
    mass_joint: np.ndarray
    mass_offset: np.ndarray
    mass_value: np.ndarray
    up: np.ndarray
    joint_rotation: np.ndarray | None = None
    mimic_names: tuple[str, ...] = ()
    mimic_joint: np.ndarray | None = None
    mimic_kind: np.ndarray | None = None
    mimic_axis: np.ndarray | None = None
    mimic_source: np.ndarray | None = None
    mimic_scale: np.ndarray | None = None
    mimic_bias: np.ndarray | None = None
    joint_labels: tuple[str, ...] = ()
    helpers: np.ndarray | None = None

    def __post_init__(self):
        if not self.joint_labels:
            object.__setattr__(self, "joint_labels", tuple(self.joint_names))
        defaults = dict(
            joint_rotation=np.tile(np.eye(3), (len(self.joint_names), 1, 1)),
            mimic_joint=np.zeros(0, np.int32),
            mimic_kind=np.zeros(0, np.int32),
            mimic_axis=np.zeros((0, 3)),
            mimic_source=np.zeros(0, np.int32),
            mimic_scale=np.zeros(0),
            mimic_bias=np.zeros(0),
            helpers=np.zeros(len(self.joint_names), bool),
        )
        for key, value in defaults.items():
            if getattr(self, key) is None:
                object.__setattr__(self, key, value)
        for key, value in vars(self).items():
            if isinstance(value, np.ndarray):
                value = np.ascontiguousarray(value)
                value.setflags(write=False)
                object.__setattr__(self, key, value)
        self._validate()

    def _validate(self) -> None:
        J, D = len(self.joint_names), len(self.dof_names)
        if J == 0:
            _fail("a skeleton needs at least one joint")
        names = list(self.joint_names) + list(self.site_names)
        for name in [*names, *self.dof_names, *self.mimic_names, *self.joint_labels]:
            if not isinstance(name, str) or not name.isprintable():
                _fail(
                    f"name {name!r} holds control characters (a terminal would run them when it is printed); "
                    "rename it with printable characters"
                )
        dupes = sorted(name for name, count in Counter(names).items() if count > 1)
        if dupes:
            _fail(f"duplicate joint/site names {dupes}; joints and sites share one namespace")
        if len(self.joint_labels) != J or len(set(self.joint_labels)) != J:
            _fail(f"joint_labels must be {J} distinct names, one per joint")
        if self.parents.shape != (J,) or self.offsets.shape != (J, 3):
            _fail(f"parents must be ({J},) and offsets ({J}, 3)")
        if self.helpers.shape != (J,) or self.helpers.dtype != bool:
            _fail(f"helpers must be ({J},) bool, one per joint")
        for k, p in enumerate(self.parents):
            if k == 0 and p != -1:
                _fail(f"joint 0 ({self.joint_names[0]!r}) must be the root with parent -1, got {p}")
            if k > 0 and not 0 <= p < k:
                _fail(
                    f"joint {k} ({self.joint_names[k]!r}) has parent index {p}: parents must be "
                    f"earlier joints (0 <= parent < {k}); a later or missing parent means a cycle "
                    "or a bad index; build with deik.model.build.build_skeleton to sort joints"
                )
        for label, arr in (
            ("offsets", self.offsets),
            ("site_offset", self.site_offset),
            ("mass_offset", self.mass_offset),
            ("dof_axis", self.dof_axis),
        ):
            bad = ~np.isfinite(arr).all(axis=-1) if arr.size else np.zeros(0, bool)
            if bad.any():
                _fail(f"{label} row {int(np.argmax(bad))} is not finite (NaN or infinite): {arr[bad][0]}")
            huge = (np.abs(arr) > MAX_LENGTH).any(axis=-1) if arr.size else np.zeros(0, bool)
            if huge.any():
                _fail(
                    f"{label} row {int(np.argmax(huge))} is {arr[huge][0]}, beyond +-{MAX_LENGTH:g} length units, "
                    "where poses lose all precision; give real lengths"
                )
        if self.joint_dof_start.shape != (J + 1,) or self.joint_dof_start[-1] != D:
            _fail(f"joint_dof_start must be ({J + 1},) ending at the DOF count {D}")
        if D and (np.abs(np.linalg.norm(self.dof_axis, axis=1) - 1.0) > 1e-6).any():
            _fail("every DOF axis must be a unit vector")
        if np.isnan(self.lower).any() or np.isnan(self.upper).any():
            _fail("joint limits must not be NaN")
        inverted = np.flatnonzero(self.lower > self.upper)
        if inverted.size:
            k = inverted[0]
            _fail(
                f"DOF {self.dof_names[k]!r} has inverted limits: lower {self.lower[k]:.6g} > "
                f"upper {self.upper[k]:.6g}; swap them"
            )
        finite = np.isfinite(np.concatenate([self.lower, self.upper]))
        huge = np.flatnonzero(finite & (np.abs(np.concatenate([self.lower, self.upper])) > MAX_LIMIT))
        if huge.size:
            k = huge[0] % D
            _fail(
                f"DOF {self.dof_names[k]!r} has limits [{self.lower[k]:.6g}, {self.upper[k]:.6g}] beyond "
                f"+-{MAX_LIMIT:g} (radians or length units), where poses lose all precision; give real limits"
            )
        if not np.isfinite(self.reference).all():
            _fail("the reference (comfort) pose must be finite")
        if not ((self.mass_value >= 0) & (self.mass_value <= MAX_MASS)).all():
            k = int(np.argmax(~((self.mass_value >= 0) & (self.mass_value <= MAX_MASS))))
            joint = self.joint_names[self.mass_joint[k]]
            _fail(f"mass {float(self.mass_value[k])} kg on joint {joint!r} must lie between 0 and {MAX_MASS:g} kg")
        if self.site_rotation.shape != (len(self.site_names), 3, 3):
            _fail("site_rotation must be (S, 3, 3)")
        for k in _improper(self.site_rotation)[:1]:
            _fail(f"site {self.site_names[k]!r} rotation is not a proper rotation matrix")
        if self.up.shape != (3,) or not np.isfinite(self.up).all() or abs(np.linalg.norm(self.up) - 1.0) > 1e-6:
            _fail(f"up must be a unit vector of 3 numbers, got {self.up.tolist()}")
        if self.joint_rotation.shape != (J, 3, 3):
            _fail(f"joint_rotation must be ({J}, 3, 3)")
        for k in _improper(self.joint_rotation)[:1]:
            _fail(f"joint {self.joint_names[k]!r} rotation is not a proper rotation matrix")
        self._validate_mimics(J, D)

    def _validate_mimics(self, J: int, D: int) -> None:
        K = len(self.mimic_names)
        arrays = (self.mimic_joint, self.mimic_kind, self.mimic_source, self.mimic_scale, self.mimic_bias)
        if any(a.shape != (K,) for a in arrays) or self.mimic_axis.shape != (K, 3):
            _fail(f"every mimic array must have {K} rows (one per mimic name)")
        if K and (np.diff(self.mimic_joint) < 0).any():
            _fail("mimic DOFs must be sorted by joint")
        for k in range(K):
            if not (0 <= self.mimic_joint[k] < J and 0 <= self.mimic_source[k] < D):
                _fail(f"mimic DOF {self.mimic_names[k]!r} names a joint or source DOF that does not exist")
            values = (*self.mimic_axis[k], self.mimic_scale[k], self.mimic_bias[k])
            if not np.isfinite(values).all() or abs(np.linalg.norm(self.mimic_axis[k]) - 1.0) > 1e-6:
                _fail(f"mimic DOF {self.mimic_names[k]!r} needs a finite unit axis, multiplier and offset")
            if abs(self.mimic_scale[k]) > MAX_MIMIC_SCALE or abs(self.mimic_bias[k]) > MAX_LENGTH:
                _fail(
                    f"mimic DOF {self.mimic_names[k]!r} has multiplier {self.mimic_scale[k]:g} and offset "
                    f"{self.mimic_bias[k]:g}; they must lie within +-{MAX_MIMIC_SCALE:g} and +-{MAX_LENGTH:g}"
                )

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def n_dofs(self) -> int:
        return len(self.dof_names)

    @property
    def n_frames(self) -> int:
        """Joints plus sites."""
        return len(self.joint_names) + len(self.site_names)

    @property
    def frame_names(self) -> tuple[str, ...]:
        return self.joint_names + self.site_names

    @property
    def total_mass(self) -> float:
        return float(self.mass_value.sum())

    @cached_property
    def full_turns(self) -> np.ndarray:
        """(D,) bool: the rotations free over a whole turn or more (a URDF continuous joint, a
        free root's): their values wrap round instead of stopping at a limit."""
        return (self.dof_kind == ROTATE) & (self.upper - self.lower >= 2 * np.pi)

    def wrapped(self, values: ArrayLike) -> np.ndarray:
        """`values` (..., D) with each full-turn DOF (full_turns) outside its limits moved by whole
        turns inside them (a continuous joint at 350 degrees is at -10); every other value as given."""
        values = np.asarray(values, np.float64)
        turn, lower, upper = 2 * np.pi, self.lower, self.upper
        above, below = np.ceil((values - upper) / turn), np.ceil((lower - values) / turn)  # whole turns past
        moved = np.where(values > upper, values - turn * above, np.where(values < lower, values + turn * below, values))
        return np.where(self.full_turns, moved, values)

    @cached_property
    def motions(self) -> Motions:
        """Free and mimic DOFs merged per joint, in the order forward kinematics applies them."""
        return Motions.of(self)

    @cached_property
    def _frame_path_length(self) -> np.ndarray:
        """(F,) bone length from the root to each frame, non-root slides at full range."""
        m = self.motions
        source_span = np.maximum(abs(self.lower), abs(self.upper))[m.source]
        slide = np.where(m.kind == TRANSLATE, abs(m.scale) * source_span + abs(m.bias), 0.0)
        depth = np.zeros(self.n_joints)
        for k in range(1, self.n_joints):
            moves = slice(m.joint_start[k], m.joint_start[k + 1])
            depth[k] = depth[self.parents[k]] + np.linalg.norm(self.offsets[k]) + slide[moves].sum()
        site = depth[self.site_joint] + np.linalg.norm(self.site_offset, axis=1)
        return np.concatenate([depth, site])

    def path_length(self, frame: int) -> float:
        """Longest distance frame `frame` can lie from the root joint's origin."""
        return float(self._frame_path_length[frame])

    @cached_property
    def reach(self) -> float:
        """Longest root-to-frame path length (sum of bone lengths); the scale of the problem."""
        longest = float(self._frame_path_length.max())
        return longest if longest > 0 else 1.0

    def root_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (3,) of where the root joint's origin can be (read-only;
        computed once: every checked target asks)."""
        return self._root_box

    @cached_property
    def _root_box(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.offsets[0].copy(), self.offsets[0].copy()
        rotated = False
        for d in range(self.joint_dof_start[0], self.joint_dof_start[1]):
            if self.dof_kind[d] != TRANSLATE:
                rotated = True
                continue
            if rotated:  # a rotation first turns this slide: it may point anywhere
                span = max(abs(self.lower[d]), abs(self.upper[d]))
                ends = np.array([[-span] * 3, [span] * 3])
            else:
                axis = self.joint_rotation[0] @ self.dof_axis[d]
                with np.errstate(invalid="ignore"):
                    ends = np.stack([axis * self.lower[d], axis * self.upper[d]])
                ends = np.nan_to_num(ends, nan=0.0)
            lo, hi = lo + ends.min(axis=0), hi + ends.max(axis=0)
        lo.setflags(write=False)
        hi.setflags(write=False)
        return lo, hi

    def frame_index(self, name: str) -> int:
        """Index of joint or site `name`; unknown names raise with close matches suggested."""
        frames = self.frame_names
        if name in frames:
            return frames.index(name)
        raise UnknownNameError(
            f"joint or site {name!r} not found in skeleton {self.name!r}{did_you_mean(name, frames)}"
        )

    def joint_dofs(self, name: str) -> slice:
        """The slice of the angle vector that belongs to joint `name`, a joint label (for a URDF
        robot the URDF joint's name; joint_labels). A site, a link or an unknown name raises a
        KeyError that says which name to give."""
        if name in self.joint_labels:
            k = self.joint_labels.index(name)
            return slice(int(self.joint_dof_start[k]), int(self.joint_dof_start[k + 1]))
        if name in self.site_names:
            raise UnknownNameError(f"{name!r} is a site, not a joint: sites have no degrees of freedom")
        if name in self.joint_names:
            label = self.joint_labels[self.joint_names.index(name)]
            raise UnknownNameError(f"{name!r} is a link (a frame); its degrees of freedom belong to joint {label!r}")
        raise UnknownNameError(
            f"joint {name!r} not found in skeleton {self.name!r}{did_you_mean(name, self.joint_labels)}"
        )

    def angles_by_joint(self, angles: np.ndarray) -> dict[str, np.ndarray]:
        """Split a pose (D,) into {joint label: its DOF values} (radians / length units), joints
        without DOFs left out; for a URDF robot the keys are its joint names, as dof_names."""
        angles = np.asarray(angles)
        slices = {n: self.joint_dofs(n) for n in self.joint_labels}
        return {n: angles[s].copy() for n, s in slices.items() if s.stop > s.start}

    def check_angles(self, angles: ArrayLike, name: str = "angles") -> np.ndarray:
        """Validate a pose array (*batch, D): finite, last axis D. Returns float64 array."""
        a = real_array(angles, name)
        if a.ndim == 0 or a.shape[-1] != self.n_dofs:
            raise InputError(f"{name} must have shape (..., {self.n_dofs}) for skeleton {self.name!r}, got {a.shape}")
        if not np.isfinite(a).all():
            raise InputError(f"{name} contain NaN or infinite values")
        return a


@dataclass(frozen=True, eq=False)
class Motions:
    """Every motion (free DOF or mimic) of a skeleton, joint by joint: joint_start (J+1,) CSR
    pointer; kind (N,); axis (N, 3); source (N,) DOF index; value = scale * q[source] + bias."""

    joint_start: np.ndarray
    kind: np.ndarray
    axis: np.ndarray
    source: np.ndarray
    scale: np.ndarray
    bias: np.ndarray

    @classmethod
    def of(cls, s: Skeleton) -> Motions:
        D = s.n_dofs
        owner = np.concatenate([s.dof_joint, s.mimic_joint])
        order = np.argsort(owner, kind="stable")  # per joint: free DOFs, then its mimics
        counts = np.bincount(owner, minlength=s.n_joints)
        return cls(
            joint_start=np.concatenate([[0], np.cumsum(counts)]).astype(np.int32),
            kind=np.concatenate([s.dof_kind, s.mimic_kind])[order].astype(np.int32),
            axis=np.concatenate([s.dof_axis, s.mimic_axis]).reshape(-1, 3)[order],
            source=np.concatenate([np.arange(D), s.mimic_source])[order].astype(np.int32),
            scale=np.concatenate([np.ones(D), s.mimic_scale])[order],
            bias=np.concatenate([np.zeros(D), s.mimic_bias])[order],
        )
