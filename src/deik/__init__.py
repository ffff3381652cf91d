"""deik: inverse kinematics by massively parallel Differential Evolution, on CPU or GPU."""

import logging

from deik.io.bvh import read_bvh, write_bvh
from deik.io.clip import Clip
from deik.io.load import load_skeleton
from deik.io.urdf import read_urdf
from deik.model.build import build_skeleton
from deik.model.builders import chain
from deik.model.humanoid import humanoid
from deik.model.joints import Dof, Joint, Segment, Site, euler, hinge, translation
from deik.model.kinematics import Kinematics, forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goals import (
    Aim,
    CentreOfMass,
    Comfort,
    ComInPolygon,
    ComOverSupport,
    Floor,
    Obstacle,
    Orientation,
    Position,
)
from deik.objectives.pose_goals import pose_goals
from deik.objectives.self_collision import SelfCollision
from deik.retarget.api import retarget
from deik.solver.engine import Engine, EvolutionState
from deik.solver.problem import Problem
from deik.solver.result import GoalReport, Result
from deik.solver.seeding import poses_around
from deik.solver.settings import Settings
from deik.solver.solve import solve, solve_batch
from deik.solver.solver import Solver

__all__ = [
    "Aim",
    "CentreOfMass",
    "Clip",
    "ComInPolygon",
    "ComOverSupport",
    "Comfort",
    "Dof",
    "Engine",
    "EvolutionState",
    "GoalReport",
    "Joint",
    "Kinematics",
    "Floor",
    "Obstacle",
    "Orientation",
    "Position",
    "Problem",
    "Result",
    "Segment",
    "SelfCollision",
    "Settings",
    "Site",
    "Skeleton",
    "Solver",
    "build_skeleton",
    "chain",
    "euler",
    "forward_kinematics",
    "hinge",
    "humanoid",
    "load_skeleton",
    "pose_goals",
    "poses_around",
    "read_bvh",
    "read_urdf",
    "retarget",
    "solve",
    "solve_batch",
    "translation",
    "write_bvh",
]
__version__ = "0.1.0"

# diagnostics go to the "deik" logger; a library adds no handler of its own (the CLI does: deik.console)
logging.getLogger("deik").addHandler(logging.NullHandler())
