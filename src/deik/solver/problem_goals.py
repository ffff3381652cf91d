"""The [[goal]] tables of a problem file (deik.solver.problem_file): one checked deik goal each.

Each table's `type` picks the goal class (GOAL_TYPES, read from the registry of goal kinds); its
fields are checked one by one and every mistake raises a ValueError naming the file, the goal
number, its type and the field.
"""

from __future__ import annotations

import math

import numpy as np

from deik.errors import InputError
from deik.model.rotations import euler_matrix
from deik.model.skeleton import Skeleton
from deik.objectives import goals as g
from deik.objectives.registry import ANGLE, COMMON_FIELDS, FILE_TYPES
from deik.suggest import did_you_mean

# type -> (goal class, required fields, optional fields besides COMMON_FIELDS), from the registry
GOAL_TYPES = {name: (row.goal, row.required, row.optional) for name, row in FILE_TYPES.items()}
# goals whose error is an angle may give their tolerance in degrees, as the command line does
DEGREE_TOLERANCE = "tolerance_degrees"
ANGLE_TYPES = tuple(name for name, row in FILE_TYPES.items() if row.unit == ANGLE)


def _is_number(value) -> bool:
    """A TOML integer or float (NaN and infinity included: they are refused by name later), but
    not a bool nor an integer too long for a float (a 401-digit number)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return isinstance(value, float) or abs(value) < 2**1023


VECTOR_FORMS = {(3,): "[x, y, z]", (3, 3): "[[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]]"}


def vector_field(value: object, shape: tuple[int, ...], where: str, field: str, form: str | None = None) -> np.ndarray:
    """A finite float64 array of `shape` from nested TOML lists, or a ValueError saying why;
    `form` describes the expected value (default: a 3-vector or 3x3 matrix template)."""

    def check(item, dims):
        if not dims:
            return _is_number(item)
        return isinstance(item, list) and len(item) == dims[0] and all(check(x, dims[1:]) for x in item)

    form = form or VECTOR_FORMS.get(shape, f"a list of {shape[0]} numbers")
    if not check(value, shape):
        raise InputError(f"{where}: field {field!r} must be {form} (finite numbers), got {value!r:.200}")
    array = np.asarray(value, dtype=np.float64)
    if not np.isfinite(array).all():
        raise InputError(f"{where}: field {field!r} contains NaN or infinity ({value!r}); give finite numbers")
    return array


def _scalar(value, field: str, where: str):
    """weight, mu, tolerance, radius, bone_radius, margin, radii: finite numbers; level: an integer >= 0."""
    if field == "level":
        if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
            return value
        raise InputError(f"{where}: field 'level' must be an integer >= 0 (0 = highest priority), got {value!r}")
    if not (_is_number(value) and math.isfinite(value)):
        raise InputError(f"{where}: field {field!r} must be a finite number, got {value!r:.80}")
    return float(value)


def _frame(skeleton: Skeleton, value, field: str, where: str) -> str:
    if not isinstance(value, str):
        raise InputError(f"{where}: field {field!r} must be a joint or site name (a string), got {value!r}")
    try:
        skeleton.frame_index(value)
    except KeyError as error:
        raise InputError(f"{where}: field {field!r}: {error.args[0]}") from None
    return value


def _joint_weights(skeleton: Skeleton, value, where: str):
    field = "joint_weights"
    if value in ("start", "end"):
        return value
    if isinstance(value, dict):
        for name, weight in value.items():
            try:
                skeleton.joint_dofs(name)
            except KeyError as error:
                raise InputError(f"{where}: field {field!r}: {error.args[0]}; weights go on joints") from None
            if not (_is_number(weight) and math.isfinite(weight) and weight >= 0):
                raise InputError(f"{where}: field {field!r}: weight of {name!r} must be a finite number >= 0")
        return {name: float(weight) for name, weight in value.items()}
    if isinstance(value, list):
        weights = vector_field(
            value, (skeleton.n_dofs,), where, field, f"a list of {skeleton.n_dofs} numbers (one per DOF)"
        )
        if (weights < 0).any():
            raise InputError(f"{where}: field {field!r} must hold weights >= 0")
        return weights
    raise InputError(
        f'{where}: field {field!r} must be "start", "end", a table {{joint = weight}} or '
        f"{skeleton.n_dofs} numbers (one per DOF), got {value!r}"
    )


# orientation table key -> (Python form, shape of the value, what it is); the form is named by the key
ORIENTATION_KEYS = {
    "target": ("matrix", (3, 3), "a 3x3 rotation matrix [[..], [..], [..]]"),
    "pose": ("matrix", (4, 4), "a 4x4 homogeneous pose [[..], [..], [..], [0, 0, 0, 1]]"),
    "quaternion_wxyz": ("quat-wxyz", (4,), "a unit quaternion [w, x, y, z]"),
    "quaternion_xyzw": ("quat-xyzw", (4,), "a unit quaternion [x, y, z, w]"),
    "rpy_degrees": ("rpy", (3,), "URDF roll, pitch, yaw [r, p, y] in degrees"),
    "euler": ("matrix", None, 'intrinsic Euler letters such as "XYZ", with degrees = [a, b, c]'),
}


def _orientation_target(table: dict, where: str) -> tuple:
    """(target, form) of an orientation table, which gives exactly one of ORIENTATION_KEYS."""
    given = [key for key in ORIENTATION_KEYS if key in table]
    forms = "; ".join(f"{key} = {text}" for key, (_, _, text) in ORIENTATION_KEYS.items())
    if len(given) != 1:
        which = f"both {given[0]!r} and {given[1]!r}" if given else "none"
        raise InputError(f"{where}: give exactly one orientation ({which} given): {forms}")
    key = given[0]
    if "degrees" in table and key != "euler":
        raise InputError(f"{where}: field 'degrees' goes with 'euler'; {key!r} needs no 'degrees'")
    form, shape, text = ORIENTATION_KEYS[key]
    if key == "rpy_degrees":
        return np.radians(vector_field(table[key], shape, where, key, text)), form
    if key != "euler":
        return vector_field(table[key], shape, where, key, text), form
    if "degrees" not in table:
        raise InputError(f"{where}: missing field 'degrees'; euler = \"XYZ\" needs degrees = [a, b, c]")
    order = table["euler"]
    if not (isinstance(order, str) and 1 <= len(order) <= 3 and set(order) <= set("XYZ")):
        raise InputError(f"{where}: field 'euler' must be 1 to 3 of the letters X, Y, Z such as \"XYZ\", got {order!r}")
    if any(a == b for a, b in zip(order, order[1:])):
        raise InputError(
            f"{where}: euler {order!r} turns about one axis twice in a row; give each next letter another axis"
        )
    degrees = vector_field(
        table["degrees"],
        (len(order),),
        where,
        "degrees",
        f"a list of {len(order)} numbers (one angle per letter of euler {order!r})",
    )
    return euler_matrix(order, np.radians(degrees)), form


def goal_from_table(skeleton: Skeleton, table: object, number: int, path: str) -> g.Goal:
    """Build and check goal `number` (1-based) from its TOML table."""
    where = f"{path}: goal {number}"
    if not isinstance(table, dict):
        raise InputError(f"{where}: must be a [[goal]] table, got {table!r}")
    kind = table.get("type")
    if kind is None:
        raise InputError(f"{where}: missing field 'type'; set type = one of {', '.join(GOAL_TYPES)}")
    if not isinstance(kind, str) or kind not in GOAL_TYPES:
        raise InputError(
            f"{where}: unknown type {kind!r}{did_you_mean(kind, GOAL_TYPES, 1)} (types: {', '.join(GOAL_TYPES)})"
        )
    where = f"{where} ({kind})"
    cls, required, optional = GOAL_TYPES[kind]
    allowed = ("type",) + required + optional + COMMON_FIELDS + ((DEGREE_TOLERANCE,) if kind in ANGLE_TYPES else ())
    for field in table:
        if field not in allowed:
            raise InputError(
                f"{where}: unknown field {field!r}{did_you_mean(field, allowed, 1)} (fields: {', '.join(allowed[1:])})"
            )
    for field in required:
        if field not in table:
            raise InputError(f"{where}: missing field {field!r} (required: {', '.join(required)})")
    kwargs = {}
    for field, value in table.items():
        if field == "type" or (kind == "orientation" and (field in ORIENTATION_KEYS or field == "degrees")):
            continue
        if field == "frame":
            kwargs[field] = _frame(skeleton, value, field, where)
        elif field == "frames":
            if not isinstance(value, list) or not value:
                raise InputError(f"{where}: field 'frames' must be a non-empty list of joint or site names")
            kwargs[field] = tuple(_frame(skeleton, name, field, where) for name in value)
        elif field in ("target", "point", "centre", "axis"):
            kwargs[field] = vector_field(value, (3,), where, field)
        elif field == "mode":
            if value not in ("sum", "max"):
                raise InputError(f'{where}: field \'mode\' must be "sum" or "max", got {value!r}')
            kwargs[field] = value
        elif field == "joint_weights":
            kwargs[field] = _joint_weights(skeleton, value, where)
        elif field == "skip":
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise InputError(f"{where}: field 'skip' must be an integer >= 1 (links), got {value!r}")
            kwargs[field] = value
        elif field == DEGREE_TOLERANCE:
            if "tolerance" in table:
                raise InputError(f"{where}: give 'tolerance' (radians) or '{DEGREE_TOLERANCE}', not both")
            kwargs["tolerance"] = math.radians(_scalar(value, field, where))
        elif field == "radii" and isinstance(value, dict):
            kwargs[field] = value  # {joint = radius}: the goal checks the names and numbers
        else:
            kwargs[field] = _scalar(value, field, where)
    if "axis" in kwargs:
        kwargs["axis"] = tuple(kwargs["axis"])
    if kind == "orientation":
        kwargs["target"], kwargs["form"] = _orientation_target(table, where)
    goal = cls(**kwargs)
    try:
        goal.row(skeleton)
    except (ValueError, KeyError) as error:
        raise InputError(f"{where}: {error.args[0]}") from None
    return goal
