"""SelfCollision in a solve: a reach that would drive the humanoid's hand through its torso is
solved without penetration when the goal is on (a level above the reach), and penetrates
without it; the penetration is measured by the NumPy oracle on the returned pose."""

import numpy as np

import deik
from deik.objectives import reference
from deik.objectives.goals import LENGTH_TOLERANCE

SETTINGS = {"population": 64, "generations": 300, "seed": 1, "restarts": 2}


def torso_reach():
    """(humanoid, pelvis pins, the left hand's target 3 cm in front of the chest joint)."""
    h = deik.humanoid()
    rest = deik.forward_kinematics(h, h.reference)
    pins = [
        deik.Position("pelvis", rest.position("pelvis"), tolerance=0.005),
        deik.Orientation("pelvis", np.eye(3), tolerance=0.01),
    ]
    return h, pins, rest.position("chest") + [0.0, 0.0, 0.03]


def penetration(skeleton, angles) -> float:
    """The default SelfCollision's error (metres) at `angles`, from the NumPy oracle."""
    return float(reference.raw_errors(deik.Problem(skeleton, [deik.SelfCollision()]), angles[None])[0, 0])


def test_a_reach_into_the_torso_stops_at_its_surface_with_self_collision():
    h, pins, target = torso_reach()
    free = deik.solve(deik.Problem(h, [*pins, deik.Position("left_hand", target, tolerance=0.01)]), **SETTINGS)
    hand = deik.forward_kinematics(h, free.angles).position("left_hand")
    assert np.linalg.norm(hand - target) <= 0.01 and penetration(h, free.angles) > 0.1  # through the chest
    goals = [*pins, deik.SelfCollision(), deik.Position("left_hand", target, tolerance=0.01, level=1)]
    kept = deik.solve(deik.Problem(h, goals), **SETTINGS)
    hand = deik.forward_kinematics(h, kept.angles).position("left_hand")
    assert penetration(h, kept.angles) <= LENGTH_TOLERANCE and kept.goals[2].error <= LENGTH_TOLERANCE
    assert np.linalg.norm(hand - target) > 0.02  # the torso is in the way: the reach is not met
    assert all(goal.met for goal in kept.goals[:3])  # the pelvis stays pinned
