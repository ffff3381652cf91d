"""fix_clip(): solve every frame of a clip at once, in a few coherence passes.

Each pass is one batched solve of all N frame problems (one kernel launch on the CPU or the
GPU). Pass k seeds frame n's population around its pass k-1 solution and pulls it towards the
mean displacement of its neighbours, so frames agree with each other without a serial sweep.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from deik.clips.problem import ClipGoals, clip_problem, fixed_goals
from deik.evolution.engine import Settings
from deik.joints import ROTATE
from deik.objectives.reference import raw_errors
from deik.objectives.table import GAIN
from deik.rotations import wrap_rotations
from deik.seeding import poses_around
from deik.solve import merge_settings, solve

CLIP_SETTINGS = {"population": 48, "generations": 300, "patience": 60}
PASSES = 3
SPREAD = (0.003, 0.3)  # radians (x reach for translations): the finest and widest seed


@dataclass(frozen=True)
class ClipFix:
    """The outcome of fix_clip: `clip` the fixed clip (same layout as the input), `original`,
    `labels` of the goals and their raw errors `before`/`after` (N, T) in length units or
    radians (NaN where a goal does not apply to a frame), `met` (N,) whether every level-0
    goal of each frame is within tolerance, `passes`, `wall_time` seconds, `settings`."""

    clip: object
    original: object
    labels: tuple[str, ...]
    before: np.ndarray
    after: np.ndarray
    met: np.ndarray
    passes: int
    wall_time: float
    settings: Settings


def _labels(problem) -> tuple[str, ...]:
    """Goal labels with the two comfort terms told apart."""
    names = []
    for goal, label in zip(problem.goals, problem.table.labels):
        if label.startswith("comfort"):
            label = "fidelity" if not any(n == "fidelity" for n in names) else "coherence"
        names.append(label)
    return tuple(names)


def _errors(problem, poses) -> np.ndarray:
    """(N, T) raw errors, NaN where the goal is not active in that frame."""
    raw = raw_errors(problem, poses, np.arange(len(poses)))
    return np.where(problem.table.params[:, :, GAIN] > 0, raw, np.nan)


def _seeds(skeleton, poses: np.ndarray, count: int, seed: int) -> np.ndarray:
    """(N, count, D) whole populations around each frame's pose (a clip fix is a local
    search), spreads from fine to wide so DE can both polish and travel."""
    spreads = np.geomspace(SPREAD[0], SPREAD[1], max(count - 1, 1))[: count - 1]
    return poses_around(skeleton, poses, count, spreads, seed=seed)


def fix_clip(clip, goals: ClipGoals, passes: int = PASSES, settings: Settings | None = None, **overrides) -> ClipFix:
    """Fix every frame of `clip` (a deik.Clip) for `goals`; `passes` >= 1 coherence passes;
    settings default to CLIP_SETTINGS (small populations: each frame starts near a solution)
    and may be overridden by keyword (population, generations, seed, device, dtype, ...)."""
    if not isinstance(goals, ClipGoals):
        raise TypeError(f"goals must be a deik.clips.problem.ClipGoals, got {type(goals).__name__}")
    if not (isinstance(passes, int) and passes >= 1):
        raise ValueError(f"passes must be an integer >= 1, got {passes!r}")
    if clip.n_frames == 0:
        raise ValueError("the clip has no frames to fix")
    settings = merge_settings("fix_clip()", settings, overrides, CLIP_SETTINGS)
    sk = clip.skeleton
    rotation = sk.dof_kind == ROTATE
    original = clip.poses()
    displacement = np.zeros_like(original)
    fixed_part = fixed_goals(clip, goals)
    start = time.perf_counter()
    for k in range(passes):
        problem = clip_problem(clip, goals, displacement, fixed_part)
        current = wrap_rotations(original + displacement, rotation)
        initial = _seeds(sk, current, settings.population, settings.seed + 7919 * k)
        result = solve(problem, settings, initial=initial)
        displacement = wrap_rotations(np.atleast_2d(result.angles) - original, rotation)
    wall = time.perf_counter() - start
    fixed = clip.with_frames(clip.frames + displacement)
    solved = wrap_rotations(original + displacement, rotation)
    level0 = np.array([gl.level == 0 for gl in problem.goals])
    after = _errors(problem, solved)
    tolerance = problem.table.term_float[:, 3]
    met = np.all(np.isnan(after[:, level0]) | (after[:, level0] <= tolerance[level0]), axis=1)
    return ClipFix(fixed, clip, _labels(problem), _errors(problem, original), after, met, passes, wall, settings)
