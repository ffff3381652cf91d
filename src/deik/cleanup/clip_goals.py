"""The clip problem: one IK problem per frame, all in one batch, with goals over frame ranges.

Levels, in strict priority (each goal within its tolerance before the next level counts):
0, the floor (every joint and site at or above it) and self-collision (the bone capsules
apart; only the DE repairs, not the warm start, pursue it), so no search trades a penetration
for anything; 1, planted contacts (a site pinned where the original clip put it during each
contact, at or above the floor by construction) and balance (the centre of mass on a track
keeping the zero-moment point over the support, cleanup/balance.py); 2, reach tracks (a site
follows targets over a frame range), so a reach never moves a planted contact or sinks a
point through the floor; 3, fidelity (stay near the original frame's pose) and coherence
(move like the neighbouring frames do, so the displacement from the original is smooth: no
pops, no jitter), each counting a DOF's change by its weight (warmstart.dof_weights).
Angles work as displacements `d` (N, D) from the original frames, so clips whose Euler channels
leave [-pi, pi] stay continuous: frame n is solved near `pose(n) + d[n]`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

import numpy as np

from deik.cleanup.balance import BalanceTrack, balance_track
from deik.cleanup.contacts import Contacts, site_positions
from deik.cleanup.plants import linked_at_heights, planted_targets, rigid_pairs
from deik.errors import InputError
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach
from deik.model.joints import ROTATE
from deik.model.rotations import wrap_rotations
from deik.objectives import goals as g
from deik.objectives.kinds import GAIN
from deik.objectives.reference import raw_errors
from deik.objectives.self_collision import SelfCollision
from deik.solver.problem import Problem

# tolerances as shares of the body's span (cleanup/body.py; 2.13 m on the shared humanoid), so
# they follow the body's size in any unit: 0.43 mm for a contact (sliding stays under 1 mm per
# frame), 5.3 mm for a reach, 1.1 cm for balance, 0.43 mm summed depth below the floor
CONTACT_TOLERANCE = 2e-4
REACH_TOLERANCE = 2.5e-3
BALANCE_TOLERANCE = 5e-3
FLOOR_TOLERANCE = 2e-4
FLOOR_LEVEL, CONTACT_LEVEL, REACH_LEVEL, FIDELITY_LEVEL = 0, 1, 2, 3
BLEND = 8  # frames over which a reach eases in and out
GRAVITY = 9.81  # metres per s^2


@dataclass(frozen=True)
class Reach:
    """A site following `targets` (N, 3) in the frames where `mask` (N,) is True, eased in and
    out over `blend` frames on each side of every run of frames (from the original motion);
    `tolerance` in length units (None: REACH_TOLERANCE x the body's span)."""

    site: str
    mask: np.ndarray
    targets: np.ndarray
    tolerance: float | None = None
    blend: int = BLEND


def eased_track(path: np.ndarray, mask: np.ndarray, targets: np.ndarray, blend: int) -> tuple[np.ndarray, np.ndarray]:
    """(mask (N,), targets (N, 3)): a track `targets` (N, 3) over the frames where `mask` (N,)
    is True, widened by `blend` frames on each side of each run, where the target eases
    (smoothstep) from the site's original `path` (N, 3) to the track's nearest end; a gap
    shorter than 2 * blend eases towards both ends at once. NaN targets outside the new mask."""
    mask = np.asarray(mask, bool)
    targets = np.where(mask[:, None], targets, path)
    N = len(mask)
    frame = np.arange(N)
    last = np.maximum.accumulate(np.where(mask, frame, -1))  # last tracked frame <= n
    next_ = np.minimum.accumulate(np.where(mask, frame, N)[::-1])[::-1]  # first tracked >= n

    def smoothstep(distance, valid):
        weight = np.clip(1.0 - distance / (blend + 1.0), 0.0, 1.0) * valid
        return weight * weight * (3 - 2 * weight)

    before = smoothstep(frame - last, last >= 0)
    after = smoothstep(next_ - frame, next_ < N)
    scale = 1.0 / np.maximum(before + after, 1.0)
    pulled = (before * scale)[:, None] * (targets[np.maximum(last, 0)] - path) + (after * scale)[:, None] * (
        targets[np.minimum(next_, N - 1)] - path
    )
    widened = mask | (before + after > 0)
    out = np.where(widened[:, None], path + pulled, np.nan)
    out[mask] = targets[mask]
    return widened, out


def blended_track(clip: Motion, reach: Reach) -> tuple[np.ndarray, np.ndarray]:
    """(mask (N,), targets (N, 3)): the reach track eased in and out over `reach.blend`
    frames from the site's original path (eased_track)."""
    path = clip.kinematics.position(reach.site)
    return eased_track(path, reach.mask, reach.targets, max(reach.blend, 0))


@dataclass(frozen=True)
class ClipGoals:
    """What to fix in a clip. `contacts`: sites to plant (None: none); `reach`: tracks;
    `balance`: keep the zero-moment point over the support of the contacts (cleanup/balance.py),
    with `gravity` in length units per s^2 (9.81 for metres); `self_collision`:
    keep the bone capsules this margin apart (None: off); `fidelity` and `coherence`: weights
    in [0, 1] of staying near the original pose and moving like the neighbouring frames;
    `floor`: the height along up (length units) every joint and site stays at or above (None:
    no floor) and `floor_clearance` (F,) how far above it each joint and site stays (a limb's
    radius; NaN: not held; None: 0, the joints and sites themselves); `plants`: where each
    contact site is held (N, S, 3) length units, NaN outside its contacts (None:
    plants.planted_targets of the clip); tolerances in length units (None: their share of the
    body's span, sized_goals). `captured`: the capture whose acceleration peaks the fix keeps
    within (cleanup/dynamics.py), when the clip fixed is not it (a capture low-passed of its
    noise, cleanup/noise.py; None: the clip itself)."""

    contacts: Contacts | None = None
    reach: tuple[Reach, ...] = ()
    balance: bool = False
    fidelity: float = 1.0
    coherence: float = 0.5
    contact_tolerance: float | None = None
    balance_tolerance: float | None = None
    self_collision: float | None = None
    floor: float | None = None
    floor_tolerance: float | None = None
    gravity: float = GRAVITY
    plants: np.ndarray | None = None
    floor_clearance: np.ndarray | None = None
    captured: Motion | None = None

    def __post_init__(self):
        object.__setattr__(self, "reach", tuple(self.reach))
        for name in ("fidelity", "coherence"):
            value = getattr(self, name)
            if not (0.0 <= value <= 1.0):
                raise InputError(f"{name} weight must lie in [0, 1], got {value}")
        if self.balance and self.contacts is None:
            raise InputError("balance needs contacts: the support polygon is made of the sites in contact")
        if not (np.isfinite(self.gravity) and self.gravity > 0):
            raise InputError(f"gravity must be a positive number (length units per s^2), got {self.gravity}")
        if self.plants is not None:
            if self.contacts is None:
                raise InputError("plants need contacts: they say where each contact site is held")
            plants = np.asarray(self.plants, float)
            expected = self.contacts.mask.shape + (3,)
            if plants.shape != expected or not np.isfinite(plants[self.contacts.mask]).all():
                raise InputError(f"plants must be finite where the contacts hold, of shape {expected}")
        if self.floor is not None and not np.isfinite(self.floor):
            raise InputError(f"the floor height must be a finite number, got {self.floor}")
        if not (
            self.contacts or self.reach or self.balance or self.floor is not None or self.self_collision is not None
        ):
            raise InputError(
                "nothing to fix: plant contacts, give a floor, add a reach track, ask for balance or self-collision"
            )


def sized_goals(goals: ClipGoals, span: float) -> ClipGoals:
    """`goals` with every tolerance left None set to its share of the body's `span` (length
    units): CONTACT_TOLERANCE, BALANCE_TOLERANCE, FLOOR_TOLERANCE and each reach's
    REACH_TOLERANCE."""
    shares = {"contact_tolerance": CONTACT_TOLERANCE, "balance_tolerance": BALANCE_TOLERANCE}
    shares["floor_tolerance"] = FLOOR_TOLERANCE
    sized = {key: share * span for key, share in shares.items() if getattr(goals, key) is None}
    reach = tuple(r if r.tolerance is not None else replace(r, tolerance=REACH_TOLERANCE * span) for r in goals.reach)
    return replace(goals, reach=reach, **sized)


def reach_names(sites: Iterable[str]) -> list[str]:
    """ "reach SITE" per reach track of `sites`, "reach SITE #2" and on for a site's later tracks."""
    names = []
    for site in sites:
        name = f"reach {site}"
        names.append(name if name not in names else f"{name} #{sum(n.startswith(name) for n in names) + 1}")
    return names


def goal_names(goals: ClipGoals) -> list[str]:
    """The name of each goal clip_problem poses for `goals`, in its order: "self-collision"
    (with its margin), "contact SITE" per site with a contact, "floor" (with a floor),
    "balance", reach_names, "fidelity", "coherence" (where their weights are > 0)."""
    contacts = goals.contacts
    names = ["self-collision"] * (goals.self_collision is not None)
    names += [] if contacts is None else [f"contact {s}" for s, on in zip(contacts.sites, contacts.mask.T) if on.any()]
    names += ["floor"] * (goals.floor is not None)
    names += ["balance"] * goals.balance
    names += reach_names(r.site for r in goals.reach)
    return names + ["fidelity"] * (goals.fidelity > 0) + ["coherence"] * (goals.coherence > 0)


def neighbour_displacement(displacement: np.ndarray) -> np.ndarray:
    """(N, D) mean displacement of each frame's neighbours (one neighbour at the ends)."""
    d = np.asarray(displacement)
    if len(d) < 2:
        return d.copy()
    padded = np.concatenate([d[1:2], d, d[-2:-1]])
    return 0.5 * (padded[:-2] + padded[2:])


def contact_plants(clip: Motion, goals: ClipGoals) -> np.ndarray:
    """(N, S, 3) where `goals` hold each contact site: its plants, else planted_targets."""
    return planted_targets(clip, goals.contacts) if goals.plants is None else np.asarray(goals.plants, float)


def plants_at_heights(clip: Motion, goals: ClipGoals, poses: np.ndarray) -> ClipGoals:
    """`goals` with each contact's plant at the height its site has in `poses` (N, D) (at least
    its floor), rigidly linked plants kept their distance apart at those heights
    (plants.linked_at_heights): the warm start holds contacts still along the ground only, and
    DE, whose contact goals are points, must not pull them back to the plants' heights."""
    contacts, up = goals.contacts, clip.skeleton.up
    plants = contact_plants(clip, goals)
    heights = site_positions(clip.with_frames(poses), contacts.sites) @ up
    if goals.floor is not None:
        heights = np.maximum(heights, goals.floor + contacts.clearance)
    moved = plants + (heights - plants @ up)[..., None] * up
    pairs = rigid_pairs(site_positions(clip, contacts.sites), body_reach(clip.skeleton), contacts.mask)
    moved = linked_at_heights(np.where(contacts.mask[..., None], moved, 0.0), contacts.mask, pairs, up)
    return replace(goals, plants=np.where(contacts.mask[..., None], moved, np.nan))


def plants_moved(clip: Motion, goals: ClipGoals, judged: ClipGoals) -> bool:
    """Whether a plant of `judged` lies farther along the ground from that of `goals` than the
    contact tolerance in some frame."""
    up = clip.skeleton.up
    move = contact_plants(clip, judged) - contact_plants(clip, goals)
    along = np.linalg.norm(move - (move @ up)[..., None] * up, axis=-1)
    return bool(np.nanmax(along, initial=0.0) > goals.contact_tolerance)


def clip_balance(
    clip: Motion, goals: ClipGoals, skip: np.ndarray | None = None, frames: np.ndarray | None = None
) -> BalanceTrack | None:
    """The centre-of-mass track for `goals` (cleanup/balance.py) over the contacts' plants, the
    frames `skip` (N,) bool left out from the start, shifting the COM of `frames` (N, D)
    (default the clip's); None without balance."""
    if not goals.balance:
        return None
    plants = contact_plants(clip, goals)
    return balance_track(clip, goals.contacts, plants, goals.gravity, skip=skip, frames=frames)


def _held_goals(clip, goals: ClipGoals, balance: BalanceTrack | None) -> list:
    """Contacts, the floor, balance (the COM on `balance`'s track) and the reach tracks, each on
    its level (module notes)."""
    out = []
    contacts = goals.contacts
    if contacts is not None:
        targets = contact_plants(clip, goals)
        for s, site in enumerate(contacts.sites):
            mask = contacts.mask[:, s]
            if mask.any():
                track = np.where(mask[:, None], targets[:, s], 0.0)
                tolerance = goals.contact_tolerance
                out.append(g.Position(site, track, active=mask, tolerance=tolerance, level=CONTACT_LEVEL))
    if goals.floor is not None:
        clearance = goals.floor_clearance
        out.append(g.Floor(goals.floor, clearance=clearance, tolerance=goals.floor_tolerance, level=FLOOR_LEVEL))
    if balance is not None:
        tolerance = goals.balance_tolerance
        out.append(g.ComOverSupport(balance.track, active=balance.steered, tolerance=tolerance, level=CONTACT_LEVEL))
    for reach in goals.reach:
        mask, targets = blended_track(clip, reach)
        track = np.where(mask[:, None], targets, 0.0)
        out.append(g.Position(reach.site, track, active=mask, tolerance=reach.tolerance, level=REACH_LEVEL))
    return out


def fixed_goals(
    clip: Motion, goals: ClipGoals, weights: np.ndarray, balance: BalanceTrack | None = None
) -> list[g.Goal]:
    """The goals that stay the same from pass to pass: contacts, floor, balance (on `balance`'s
    track, clip_balance when None), reach and fidelity, which counts each DOF's change by
    `weights` (D,) (warmstart.dof_weights)."""
    out = _held_goals(clip, goals, clip_balance(clip, goals) if balance is None else balance)
    if goals.fidelity > 0:
        level = FIDELITY_LEVEL
        out.append(g.Comfort(weight=goals.fidelity, level=level, reference=clip.poses(), joint_weights=weights))
    return out


def clip_problem(
    clip: Motion, goals: ClipGoals, displacement: np.ndarray, weights: np.ndarray, fixed: list[g.Goal] | None = None
) -> Problem:
    """The batch of N frame problems for `clip` given the current displacement (N, D) of every
    frame from the original (coherence pulls each frame towards its neighbours' displacement,
    each DOF counted by `weights` (D,)); `fixed`: fixed_goals(clip, goals, weights) when already
    computed."""
    sk = clip.skeleton
    goal_list = list(fixed_goals(clip, goals, weights) if fixed is None else fixed)
    if goals.self_collision is not None:
        goal_list.insert(0, SelfCollision(margin=goals.self_collision))
    if goals.coherence > 0:
        smooth = wrap_rotations(clip.poses() + neighbour_displacement(displacement), sk.dof_kind == ROTATE)
        goal_list.append(
            g.Comfort(weight=goals.coherence, level=FIDELITY_LEVEL, reference=smooth, joint_weights=weights)
        )
    return Problem(sk, goal_list)


def goal_errors(problem: Problem, poses: np.ndarray) -> np.ndarray:
    """(N, T) raw errors of `problem`'s goals at `poses` (N, D), NaN where a goal is not active
    in that frame."""
    raw = raw_errors(problem, poses, np.arange(len(poses)))
    return np.where(problem.table.params[:, :, GAIN] > 0, raw, np.nan)


def frames_within(problem: Problem, errors: np.ndarray, levels: Callable[[int], bool]) -> np.ndarray:
    """(N,) frames whose goals on the priority `levels` chosen (levels(level) -> bool) all lie
    within tolerance, of `errors` (N, T) as goal_errors."""
    chosen = np.array([levels(goal.level) for goal in problem.goals], bool)
    within = errors[:, chosen] <= problem.table.term_float[chosen, 3]
    return np.all(np.isnan(errors[:, chosen]) | within, axis=1)


def floor_depths(problem: Problem, errors: np.ndarray) -> np.ndarray:
    """(N,) how deep under the floor the body goes in each frame, summed over its points
    (length units: the Floor goal's error among `errors` (N, T) as goal_errors), 0 without a
    floor."""
    columns = [t for t, goal in enumerate(problem.goals) if isinstance(goal, g.Floor)]
    return np.nan_to_num(errors[:, columns]).max(axis=1, initial=0.0)


def met_frames(problem: Problem, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(errors (N, T) as goal_errors, met (N,): every contact, floor, balance and reach goal of
    the frame (the levels above fidelity) within tolerance) at `poses` (N, D)."""
    errors = goal_errors(problem, poses)
    return errors, frames_within(problem, errors, lambda level: level < FIDELITY_LEVEL)
