"""deik: inverse kinematics by massively parallel Differential Evolution, on CPU or GPU.

`import deik` loads no NumPy, Numba or kernels: each public name is imported from its module on
first use (PEP 562), so a script or command pays only for what it uses.
"""

import importlib
import logging

# the module that defines each public name
_MODULES = {
    "deik.cleanup.clean": ("CleanedClip", "CleanOptions", "clean_clip"),
    "deik.cli.solve_command": ("problem_from_flags",),
    "deik.errors": (
        "DeikError",
        "DeviceError",
        "FileFormatError",
        "InputError",
        "SolveError",
        "UnknownNameError",
        "UsageError",
    ),
    "deik.experiments.demo": ("demo",),
    "deik.experiments.runner": ("run_experiments",),
    "deik.io.bvh": ("read_bvh", "write_bvh"),
    "deik.io.describe": ("describe_skeleton",),
    "deik.io.limits": ("range_of_motion", "read_limits", "with_limits", "write_limits"),
    "deik.io.motion": ("Clip",),
    "deik.io.load": ("load_skeleton",),
    "deik.io.urdf": ("read_urdf",),
    "deik.model.build": ("build_skeleton",),
    "deik.model.builders": ("chain",),
    "deik.model.humanoid": ("humanoid",),
    "deik.model.joints": ("Dof", "Joint", "Segment", "Site", "euler", "hinge", "translation"),
    "deik.model.kinematics": ("Kinematics", "forward_kinematics"),
    "deik.model.skeleton": ("Skeleton",),
    "deik.objectives.goals": (
        "Aim",
        "CentreOfMass",
        "Comfort",
        "ComInPolygon",
        "ComOverSupport",
        "Floor",
        "Obstacle",
        "Orientation",
        "Position",
    ),
    "deik.objectives.pose_goals": ("pose_goals",),
    "deik.objectives.self_collision": ("SelfCollision",),
    "deik.retargeting.api": ("retarget",),
    "deik.solver.engine": ("Engine", "EvolutionState"),
    "deik.solver.problem": ("Problem",),
    "deik.solver.problem_file": ("ProblemFile", "load_problem"),
    "deik.solver.result": ("GoalReport", "Result"),
    "deik.solver.seeding": ("poses_around",),
    "deik.solver.settings": ("Settings",),
    "deik.solver.solve": ("solve", "solve_batch"),
    "deik.solver.reusable": ("Solver",),
    "deik.solver.warmup": ("warmup",),
    "deik.viz.view": ("ViewOptions", "view", "view_scene"),
}
_EXPORTS = {name: module for module, names in _MODULES.items() for name in names}
__all__ = sorted(_EXPORTS)
__version__ = "0.1.0"


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'deik' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


# diagnostics go to the "deik" logger; a library adds no handler of its own (the CLI does: deik.console)
logging.getLogger("deik").addHandler(logging.NullHandler())
