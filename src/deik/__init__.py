"""deik: inverse kinematics by massively parallel Differential Evolution, on CPU or GPU.

`import deik` loads no NumPy, Numba or kernels: each public name is imported from its module on
first use (PEP 562), so a script or command pays only for what it uses.
"""

import importlib
import logging
from typing import TYPE_CHECKING

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

# The type checker sees each public name with its real type (imported `as` itself: an explicit re-export);
# tests/model/test_annotations.py keeps these imports in step with _MODULES.
if TYPE_CHECKING:
    from deik.cleanup.clean import CleanedClip as CleanedClip
    from deik.cleanup.clean import CleanOptions as CleanOptions
    from deik.cleanup.clean import clean_clip as clean_clip
    from deik.cli.solve_command import problem_from_flags as problem_from_flags
    from deik.errors import DeikError as DeikError
    from deik.errors import DeviceError as DeviceError
    from deik.errors import FileFormatError as FileFormatError
    from deik.errors import InputError as InputError
    from deik.errors import SolveError as SolveError
    from deik.errors import UnknownNameError as UnknownNameError
    from deik.errors import UsageError as UsageError
    from deik.experiments.demo import demo as demo
    from deik.experiments.runner import run_experiments as run_experiments
    from deik.io.bvh import read_bvh as read_bvh
    from deik.io.bvh import write_bvh as write_bvh
    from deik.io.describe import describe_skeleton as describe_skeleton
    from deik.io.limits import range_of_motion as range_of_motion
    from deik.io.limits import read_limits as read_limits
    from deik.io.limits import with_limits as with_limits
    from deik.io.limits import write_limits as write_limits
    from deik.io.load import load_skeleton as load_skeleton
    from deik.io.motion import Clip as Clip
    from deik.io.urdf import read_urdf as read_urdf
    from deik.model.build import build_skeleton as build_skeleton
    from deik.model.builders import chain as chain
    from deik.model.humanoid import humanoid as humanoid
    from deik.model.joints import Dof as Dof
    from deik.model.joints import Joint as Joint
    from deik.model.joints import Segment as Segment
    from deik.model.joints import Site as Site
    from deik.model.joints import euler as euler
    from deik.model.joints import hinge as hinge
    from deik.model.joints import translation as translation
    from deik.model.kinematics import Kinematics as Kinematics
    from deik.model.kinematics import forward_kinematics as forward_kinematics
    from deik.model.skeleton import Skeleton as Skeleton
    from deik.objectives.goals import Aim as Aim
    from deik.objectives.goals import CentreOfMass as CentreOfMass
    from deik.objectives.goals import Comfort as Comfort
    from deik.objectives.goals import ComInPolygon as ComInPolygon
    from deik.objectives.goals import ComOverSupport as ComOverSupport
    from deik.objectives.goals import Floor as Floor
    from deik.objectives.goals import Obstacle as Obstacle
    from deik.objectives.goals import Orientation as Orientation
    from deik.objectives.goals import Position as Position
    from deik.objectives.pose_goals import pose_goals as pose_goals
    from deik.objectives.self_collision import SelfCollision as SelfCollision
    from deik.retargeting.api import retarget as retarget
    from deik.solver.engine import Engine as Engine
    from deik.solver.engine import EvolutionState as EvolutionState
    from deik.solver.problem import Problem as Problem
    from deik.solver.problem_file import ProblemFile as ProblemFile
    from deik.solver.problem_file import load_problem as load_problem
    from deik.solver.result import GoalReport as GoalReport
    from deik.solver.result import Result as Result
    from deik.solver.reusable import Solver as Solver
    from deik.solver.seeding import poses_around as poses_around
    from deik.solver.settings import Settings as Settings
    from deik.solver.solve import solve as solve
    from deik.solver.solve import solve_batch as solve_batch
    from deik.solver.warmup import warmup as warmup
    from deik.viz.view import ViewOptions as ViewOptions
    from deik.viz.view import view as view
    from deik.viz.view import view_scene as view_scene
else:  # at run time each name is imported on first use

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
