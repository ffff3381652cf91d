"""deik: inverse kinematics by massively parallel Differential Evolution, on CPU or GPU."""

from deik.builders import chain
from deik.evolution.engine import Engine, EvolutionState, Settings
from deik.humanoid import humanoid
from deik.joints import Dof, Joint, Segment, Site, build_skeleton, euler, hinge, translation
from deik.kinematics import Kinematics, forward_kinematics
from deik.objectives.goals import (
    Aim,
    CentreOfMass,
    ComInPolygon,
    ComOverSupport,
    Comfort,
    Obstacle,
    Orientation,
    Position,
)
from deik.problem import Problem
from deik.result import GoalReport, Result
from deik.skeleton import Skeleton
from deik.solve import solve

__all__ = [
    "Aim", "CentreOfMass", "ComInPolygon", "ComOverSupport", "Comfort", "Dof", "Engine",
    "EvolutionState", "GoalReport", "Joint", "Kinematics", "Obstacle", "Orientation", "Position",
    "Problem", "Result", "Segment", "Settings", "Site", "Skeleton", "build_skeleton", "chain",
    "euler", "forward_kinematics", "hinge", "humanoid", "solve", "translation",
]
__version__ = "0.1.0"
