"""deik.clean_clip(): clean a whole clip from one options object (what `deik clip` does).

    cleaned = deik.clean_clip("walk.bvh", deik.CleanOptions(balance=True))
    deik.write_bvh("walk_fixed.bvh", cleaned.clip)
    cleaned.report["metrics"]["sliding_max_mm_per_frame"]    # before and after
    cleaned.unmet_frames, cleaned.skipped_balance_frames          # what it could not do

The options take the flags' forms (cleanup/specs.py), so a folder run gives the same
CleanOptions to every clip. plan_clean resolves them against one clip (contacts detected,
floor, reach tracks, length unit) and CleanPlan.run fixes it (cleanup/fix.py) and records the
outcome (cleanup/document.py); clean_clip does both.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from numbers import Real

import numpy as np

from deik.cleanup.body import Body, body_of, on_body, with_helpers
from deik.cleanup.clip_goals import FLOOR_TOLERANCE, GRAVITY, ClipGoals, Reach
from deik.cleanup.contacts import Contacts
from deik.cleanup.cuts import Cuts, find_cuts
from deik.cleanup.document import clip_document
from deik.cleanup.dynamics import FAR_DEGREES
from deik.cleanup.fix import ClipFix, fix_clip
from deik.cleanup.floor import penetration
from deik.cleanup.ground import SPEED, FloorChoice, Paths, body_paths, clearances
from deik.cleanup.noise import Noise, capture_noise, low_passed
from deik.cleanup.specs import all_contacts, floor_choice, reaches
from deik.cleanup.units import METRES, unit_of_span
from deik.cleanup.up_axis import floor_it_rests_on
from deik.errors import InputError
from deik.io.euler import canonical_frames
from deik.io.files import FilePath
from deik.io.motion import Clip, message_prefix
from deik.io.trajectory import Motion, Trajectory

log = logging.getLogger(__name__)
# the DE settings the options may override
SETTINGS = ("population", "generations", "seed", "device", "time_limit", "memory_limit")


def _texts(value, name: str) -> tuple[str, ...]:
    """A spec or a sequence of specs as a tuple of strings; InputError otherwise."""
    if isinstance(value, str):
        return (value,)
    if not isinstance(value, Sequence) or not all(isinstance(item, str) for item in value):
        raise InputError(f"{name} takes a spec (text) or a list of specs, got {value!r}")
    return tuple(value)


NUMBERS = (  # (field, low, high, above low only) of CleanOptions' numbers, the ranges of their flags
    ("contact_height", 0.0, math.inf, False),
    ("contact_speed", 0.0, math.inf, True),  # at 0 nothing rests, so nothing is planted
    ("self_collision", 0.0, math.inf, False),
    ("fidelity", 0.0, 1.0, False),
    ("coherence", 0.0, 1.0, False),
    ("time_limit", 0.0, math.inf, True),
    ("memory_limit", 0.0, math.inf, True),
)


@dataclass(frozen=True)
class CleanOptions:
    """What to fix in a clip and how: the flags of `deik clip`, one field each, in their forms.

    - `plant_feet`: "auto", "none" or "SITE:A-B[,A-B...]" specs (default: auto, the heel and
      toe of each foot where they rest); `contact`: "auto", "none", "POINT" or
      "POINT@A-B[,A-B...]" (a joint, an end site or a bone PARENT-CHILD; default: auto, every
      other point of the body where it rests); `contact_height` (length units) and
      `contact_speed` (length units/s): detection thresholds (None: the defaults, shares of
      the body's span).
    - `floor`: "auto" (detected and kept), "none" or a height (length units along up).
    - `balance`: keep the zero-moment point over the support; `self_collision`: a margin
      (length units) the bone capsules keep, None for off; `reach`: "SITE=track.csv",
      "SITE=track.json" or "SITE=X,Y,Z@A:B" tracks.
    - `fidelity`, `coherence`: weights in [0, 1] of staying near the capture and moving like
      the neighbouring frames.
    - `passes`, `population`, `generations`, `seed`, `device`: the DE repairs (None: the
      defaults of cleanup/fix.py); `time_limit` (seconds) stops the DE passes (the warm start
      always runs), `memory_limit` (GiB) bounds what they may allocate.
    - `limits`: a joint-limits table (JSON, `deik limits`) every frame must lie within;
      `units`: the clip's length unit ("m", "cm", "mm", "in"; None: guessed from its size).

    Mistakes raise deik.InputError naming the flag and the spec.
    """

    plant_feet: tuple[str, ...] = ()
    contact: tuple[str, ...] = ()
    floor: str | float | None = "auto"
    contact_height: float | None = None
    contact_speed: float | None = None
    balance: bool = False
    self_collision: float | None = None
    reach: tuple[str, ...] = ()
    fidelity: float = 1.0
    coherence: float = 0.5
    passes: int | None = None
    population: int | None = None
    generations: int | None = None
    seed: int | None = None
    device: str | None = None
    time_limit: float | None = None
    memory_limit: float | None = None
    limits: str | None = None
    units: str | None = None

    def __post_init__(self):
        for name in ("plant_feet", "contact", "reach"):
            object.__setattr__(self, name, _texts(getattr(self, name), name))
        if self.limits is not None:
            if not isinstance(self.limits, (str, os.PathLike)):
                raise InputError(f"limits: give the path of a limits table (JSON), got a {type(self.limits).__name__}")
            object.__setattr__(self, "limits", str(self.limits))
        if self.units is not None and self.units not in METRES:
            raise InputError(f"--units {self.units!r}: use one of {', '.join(sorted(METRES))}")
        if not isinstance(self.balance, (bool, np.bool_)):
            raise InputError(f"balance: give True or False, got {self.balance!r:.40}")
        for name, low, high, above in NUMBERS:  # as the flags check them
            value = getattr(self, name)
            if value is None and name not in ("fidelity", "coherence"):
                continue
            inside = isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value)
            if not (inside and (value > low if above else value >= low) and value <= high):
                shown = f"{'above' if above else 'from'} {low:g}" + (f" to {high:g}" if high < math.inf else "")
                raise InputError(f"--{name.replace('_', '-')} {value!r:.40}: give a finite number {shown}")

    def settings(self) -> dict:
        """The DE settings given (SETTINGS), for fix_clip: memory_limit in bytes."""
        given = {name: getattr(self, name) for name in SETTINGS if getattr(self, name) is not None}
        if "memory_limit" in given:
            given["memory_limit"] = max(1, int(given["memory_limit"] * 2**30))
        return given


@dataclass(frozen=True)
class CleanedClip:
    """The outcome of clean_clip: `clip` the fixed clip (the input's channel layout), `original`
    the clip it was made from, `report` the record `deik clip --json` writes (metrics before
    and after, goal errors per frame, contacts, floor, balance, dynamics: cleanup/document.py),
    `fix` the fix itself (cleanup/fix.ClipFix: errors per goal and frame, stages, settings),
    the `contacts` planted (None for none), the `floor` height (length units along up), and the length `unit` (with
    `unit_guessed` when no unit was given). What it could not do: `unmet_frames`,
    `skipped_balance_frames`, `unreachable` and `far_joints`."""

    clip: Motion
    original: Motion
    report: dict
    fix: ClipFix
    contacts: Contacts | None
    floor: float
    unit: str
    unit_guessed: bool

    @property
    def unmet_frames(self) -> list[int]:
        """Frames that miss a contact, floor, balance, reach or self-collision goal, sink under
        the floor stated or let a resting point slide (cleanup/verdict.py)."""
        return [n for n, met in enumerate(self.report["met_per_frame"]) if not met]

    @property
    def skipped_balance_frames(self) -> list[int]:
        """Frames whose balance was left out (holding it would make the motion jolt); [] without balance."""
        balance = self.report["balance"]
        return [] if balance is None else list(balance["skipped_frames"])

    @property
    def unreachable(self) -> dict[str, dict]:
        """{reach goal key: {"frames": [...], "distance_mm": [...]}} of the reach tracks out of
        reach in some frames (the contacts and the floor come first)."""
        return {key: missed for key, missed in self.report["reach_unreached"].items() if missed["frames"]}

    @property
    def far_joints(self) -> list[dict]:
        """[{"frame", "joint", "deviation_deg"}] of the joints turned more than FAR_DEGREES from the capture."""
        return list(self.report["joints_far_from_capture"]["joint_frames"])


@dataclass(frozen=True)
class CleanPlan:
    """A clip and its goals, resolved from CleanOptions (plan_clean): `clip` (within the limits
    table, if given), the `body` it is fixed on (cleanup/body.py: soles, radii, span), `goals`,
    the `contacts` (None for none), the `floor` (ground.FloorChoice: height, how it was found)
    with whether it is `floor_kept` as a goal, the `reach` tracks and the length `unit`
    (`unit_guessed` when no unit was given); `captured` the clip as given, its `cuts` and its
    capture `noise` (the fix sees `clip`: cuts.stand_in of it, cleanup/cuts.py, low-passed when
    noisy, cleanup/noise.py)."""

    clip: Motion
    options: CleanOptions
    body: Body
    goals: ClipGoals
    contacts: Contacts | None
    floor: FloorChoice
    floor_kept: bool
    reach: tuple[Reach, ...]
    unit: str
    unit_guessed: bool
    captured: Motion
    cuts: Cuts
    noise: Noise

    def run(self, progress: Callable[[int, str], object] | None = None) -> CleanedClip:
        """Fix the clip (cleanup/fix.fix_clip) and record the outcome; `progress(met, stage)` as fix_clip's."""
        settings = self.options.settings()
        fix = fix_clip(self.clip, self.goals, passes=self.options.passes, progress=progress, body=self.body, **settings)
        tracks = [(r.site, r.mask, r.targets) for r in self.reach]
        floor = self.floor.record() | {"kept": self.floor_kept}
        report = clip_document(fix, self.contacts, tracks, self.unit, METRES[self.unit], FAR_DEGREES, floor)
        report["noise"] = self.noise.record()
        clip, report = self._with_kept_frames(fix.clip, report)
        height = self.floor.height
        return CleanedClip(clip, self.captured, report, fix, self.contacts, height, self.unit, self.unit_guessed)

    def _with_kept_frames(self, fixed: Motion, report: dict) -> tuple[Motion, dict]:
        """The fixed clip with the frames the cuts keep written back as captured, and the report
        saying so: such a frame is met when nothing of the body lies under the floor in it."""
        report = report | {"cuts": self.cuts.record()}
        kept = np.flatnonzero(self.cuts.kept)
        if not len(kept):
            return fixed, report
        clip = replace(fixed, frames=np.where(self.cuts.kept[:, None], self.captured.frames, fixed.frames))
        part = on_body(replace(clip, frames=clip.frames[kept]), self.body)
        depth = penetration(part.kinematics, self.body.skeleton, self.floor.height, clearances(self.body))
        met = np.array(report["met_per_frame"], bool)
        met[kept] = depth <= FLOOR_TOLERANCE * self.body.span
        return clip, report | {"met_per_frame": met.tolist(), "frames_met": int(met.sum())}


def _within_limits(clip: Motion, path: str) -> Motion:
    """`clip` on its skeleton narrowed to the limits table at `path`; InputError for a frame outside."""
    from deik.io.limits import clip_within, read_limits, with_limits

    return clip_within(clip, with_limits(clip.skeleton, read_limits(path, clip.skeleton)), f"--limits {path}")


def read_clip(clip: Motion | FilePath) -> Motion:
    """`clip` as it is (a deik.Clip or a Trajectory), or the BVH file at that path."""
    if isinstance(clip, (Clip, Trajectory)):
        return clip
    from deik.io.bvh import read_bvh

    return read_bvh(clip)


def without_shake(clip: Clip, body: Body) -> tuple[Clip, Noise, Trajectory, Paths]:
    """(`clip` low-passed when its capture noise calls for it, cleanup/noise.py; the Noise; its
    frames on `body` and their Paths). The shake goes first: it hides rests, and it stays
    wherever nothing is planted or tracked."""
    motion = on_body(clip, body)
    paths = body_paths(motion, body)
    noise = capture_noise(paths.positions[:, body.own], body.span, clip.frame_time, SPEED * body.span)
    if noise.low_pass is None:
        return clip, noise, motion, paths
    clip = clip.with_frames(low_passed(clip.skeleton, clip.frames, noise.low_pass, clip.frame_time))
    motion = on_body(clip, body)
    return clip, noise, motion, replace(body_paths(motion, body), captured=paths.positions)


def plan_clean(clip: Motion | FilePath, options: CleanOptions | None = None) -> CleanPlan:
    """Resolve `options` (default CleanOptions()) against `clip` (a deik.Clip or a BVH path):
    the limits, floor, contacts, reach tracks and length unit; says on the "deik" logger which
    unit, floor and contacts it took. InputError for a spec that does not fit the clip."""
    options = CleanOptions() if options is None else options
    if not isinstance(options, CleanOptions):
        raise TypeError(f"options must be a deik.CleanOptions, got {type(options).__name__}")
    clip = read_clip(clip)
    if clip.n_frames == 0:
        raise InputError(f"{message_prefix(clip)}the clip has no frames (Frames: 0) to fix; give one with motion")
    if options.limits:  # checked on the values as written, as `deik limits` measures them
        clip = _within_limits(clip, options.limits)
    clip = replace(clip, frames=canonical_frames(clip.skeleton, clip.frames))  # turns and Euler twins are no motion
    clip = with_helpers(clip)
    captured, body = clip, body_of(clip)
    cuts = find_cuts(clip, body.span)
    clip = cuts.stand_in(clip)
    if clip is not captured:  # the body as the motion without its jumps shows it
        body = body_of(clip)
    unfiltered = clip
    clip, noise, motion, paths = without_shake(clip, body)
    floor, keep_floor = floor_choice(motion, body, options.floor, paths)
    if options.floor == "auto":
        floor = floor_it_rests_on(clip, body, paths, floor)
    thresholds = (options.contact_height, options.contact_speed)
    contacts = all_contacts(motion, body, (options.plant_feet, options.contact), floor.height, thresholds, paths)
    reach = reaches(clip, options.reach)
    unit = options.units or unit_of_span(body.span)
    if options.units and not 0.1 <= body.span * METRES[unit] <= 50.0:  # no body a clip is made of is that size
        log.warning(
            f"--units {unit}: the body would span {body.span * METRES[unit]:.3g} m from end to end; "
            f"its size says {unit_of_span(body.span)}"
        )
    goals = ClipGoals(
        contacts,
        reach,
        options.balance,
        options.fidelity,
        options.coherence,
        self_collision=options.self_collision,
        floor=floor.height if keep_floor else None,
        gravity=GRAVITY / METRES[unit],
        captured=None if clip is unfiltered else unfiltered,
    )
    if not options.units:
        log.info(
            f"reports in {unit}: the body spans {body.span:.4g} length units from end to end, a person's size in "
            f"{unit}; --units sets them (the fix itself needs no unit)"
        )
    if contacts is not None:
        described = contacts.describe().replace("\n", "\n  ")
        log.info("contacts" + (" (detected)" if contacts.detected else "") + ":\n  " + described)
    return CleanPlan(
        clip=clip,
        options=options,
        body=body,
        goals=goals,
        contacts=contacts,
        floor=floor,
        floor_kept=keep_floor,
        reach=reach,
        unit=unit,
        unit_guessed=not options.units,
        captured=captured,
        cuts=cuts,
        noise=noise,
    )


def clean_clip(
    clip: Motion | FilePath,
    options: CleanOptions | None = None,
    *,
    progress: Callable[[int, str], object] | None = None,
) -> CleanedClip:
    """Clean `clip` (a deik.Clip, or a BVH path; for masses from a segment table read it with
    deik.read_bvh(path, segments=...)) as `options` (deik.CleanOptions, default: plant the feet
    detected, keep the floor) ask, all frames at once: a smooth warm start, then DE repairs of
    the frames still missing a goal. `progress(met, stage)` is told the frames meeting every
    goal after each stage. Returns a CleanedClip (the fixed clip, its report, what it could
    not do); InputError (a ValueError) for options that do not fit the clip."""
    return plan_clean(clip, options).run(progress)
