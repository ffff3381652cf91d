"""The contact, floor and reach specs of a clip cleaning (deik.CleanOptions, the flags of
`deik clip`) resolved against one clip: which sites are planted when, the floor, the tracks.

Specs are text in the flags' forms, so a folder run can give the same ones to every clip and
each clip resolves them against its own frames and names. A spec that does not fit the clip
raises InputError naming the flag, the spec and what to give instead.

    plant_feet   auto | none | SITE:A-B[,A-B...]            (repeatable; A-B inclusive)
    contact      auto | none | POINT | POINT@A-B[,A-B...]   (POINT a joint, an end site or a bone PARENT-CHILD)

Each of plant_feet and contact is auto when not given (every point of the body that rests
is planted by default); a spec given replaces that default for its points only.
    floor        auto | none | HEIGHT                       (length units along up)
    reach        SITE=track.csv | SITE=track.json | SITE=X,Y,Z@A:B
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence

import numpy as np

from deik.cleanup.body import Body
from deik.cleanup.body_contacts import bone_contacts, bone_ends, merge_contacts
from deik.cleanup.clip_goals import Reach
from deik.cleanup.contacts import Contacts
from deik.cleanup.ground import (
    FloorChoice,
    Paths,
    body_paths,
    detect_floor,
    detect_resting,
    given_contacts,
)
from deik.cleanup.tracks import parse_reach_spec
from deik.errors import InputError
from deik.io.trajectory import Motion
from deik.objectives.goal_values import check_reachable
from deik.suggest import did_you_mean

log = logging.getLogger(__name__)

PLANT_FORMS = "auto, none, or SITE:A-B[,A-B...] (repeatable)"
CONTACT_FORMS = (
    "auto (every joint and end site, detected), none, or POINT[@A-B[,A-B...]] (repeatable): POINT a "
    "joint, an end site or a bone PARENT-CHILD, detected without @, in contact over frames A-B "
    "(inclusive) with it"
)


def check_site(clip: Motion, site: str, flag: str) -> None:
    """InputError naming `flag`, the unknown `site` and the names to choose from."""
    sk = clip.skeleton
    if site not in sk.frame_names:
        raise InputError(
            f"{flag}: no joint or site {site!r} in {os.path.basename(clip.source) or 'the clip'}"
            f"{did_you_mean(site, sk.frame_names)}; its sites are {', '.join(sk.site_names)} "
            f"and its joints {', '.join(sk.joint_names)}"
        )


def frame_spans(form: str, spans: str, n_frames: int, flag: str) -> list[tuple[int, int]]:
    """(start, stop) ranges, stop exclusive, of A-B[,A-B...] (inclusive), else InputError."""
    out = []
    for span in spans.split(","):
        start, _, stop = span.partition("-")
        if not all(part.strip().isdigit() and len(part.strip()) <= 12 for part in (start, stop)):
            raise InputError(f"{flag} {form!r}: frame range {span!r} must read A-B (inclusive)")
        start, stop = int(start), int(stop)
        if not start <= stop < n_frames:
            raise InputError(
                f"{flag} {form!r}: frames {start}-{stop} are outside the clip or "
                f"reversed; valid frames: 0..{n_frames - 1} (A-B, both inclusive)"
            )
        out.append((start, stop + 1))
    return out


def planted_feet(clip: Motion, body: Body, floor: float, forms: Sequence[str], detect: dict) -> Contacts | None:
    """The plant_feet contacts of `forms` on `body` (None for none; auto when `forms` is
    empty): each foot's heel and toe where they rest on the floor at `floor`. `detect`: the
    keywords of ground.detect_resting (band, speed, paths)."""
    forms = list(forms) or ["auto"]
    if forms == ["none"]:
        return None
    for alone in ("auto", "none"):
        if alone in forms and len(forms) > 1:
            raise InputError(f"--plant-feet {alone} cannot be combined with other values of it; use {PLANT_FORMS}")
    if "auto" in forms:
        points = tuple(name for foot in body.feet for name in (foot.heel, foot.toe))
        return detect_resting(clip, body, floor, points, idle=False, **detect) if points else None
    masks = {}
    for form in forms:
        site, _, spans = form.partition(":")
        if not site or not spans:
            raise InputError(f"--plant-feet {form!r}: use {PLANT_FORMS}")
        check_site(clip, site, f"--plant-feet {form!r}")
        mask = masks.setdefault(site, np.zeros(clip.n_frames, bool))
        for start, stop in frame_spans(form, spans, clip.n_frames, "--plant-feet"):
            mask[start:stop] = True
    return given_contacts(clip, body, floor, masks)


def _point(clip: Motion, point: str, form: str) -> tuple[str, ...]:
    """(parent, child) of a bone PARENT-CHILD, or (point,) of a joint or site; else InputError."""
    if point in clip.skeleton.frame_names:
        return (point,)
    ends = bone_ends(clip.skeleton, point)
    if ends is None:
        check_site(clip, point, f"--contact {form!r} (a joint, an end site or a bone PARENT-CHILD)")
    return ends


def body_contacts(clip: Motion, body: Body, floor: float, forms: Sequence[str], detect: dict) -> list[Contacts]:
    """The contact specs `forms` of points anywhere on `body`, one Contacts per form, on the
    floor at `floor` (auto when `forms` is empty: every point of the body that rests, the feet's
    heels and toes aside, which plant_feet gives). `detect`: as planted_feet's."""
    forms = list(forms) or ["auto"]
    if forms == ["none"]:
        return []
    feet = {name for foot in body.feet for name in (foot.heel, foot.toe)}
    parts = []
    for form in forms:
        if form in ("auto", "none"):
            if form == "none":
                raise InputError(f"--contact none cannot be combined with other --contact values; use {CONTACT_FORMS}")
            points = tuple(name for name in body.contact_points() if name not in feet)
            parts.append(detect_resting(clip, body, floor, points, idle=False, **detect))
            continue
        point, at, spans = form.partition("@")
        ends = _point(clip, point.strip(), form)
        if not at:
            parts.append(detect_resting(clip, body, floor, ends, **detect))
            continue
        frames = np.zeros(clip.n_frames, bool)
        for start, stop in frame_spans(form, spans, clip.n_frames, "--contact"):
            frames[start:stop] = True
        masks = bone_contacts(clip, *ends, frames) if len(ends) == 2 else {ends[0]: frames}
        parts.append(given_contacts(clip, body, floor, masks))
    return parts


MAX_FLOOR = 1e12  # a floor height beyond this is a typo (its squares overflow float32)
FAR_BELOW = 0.5  # x the body's span: a given floor further below its lowest point is warned about


def floor_choice(clip: Motion, body: Body, spec: str | float | None, paths: Paths) -> tuple[FloorChoice, bool]:
    """(the floor, whether it is kept as a goal) of the floor spec: "auto" (detected and kept),
    "none" or None (detected, for the measures, and not kept) or a height (length units)."""
    if spec is None or spec in ("auto", "none"):
        return detect_floor(clip, body, paths), spec == "auto"
    try:
        height = float(spec)
    except (TypeError, ValueError, OverflowError):
        height = float("nan")
    if not (np.isfinite(height) and abs(height) <= MAX_FLOOR):
        raise InputError(
            f"--floor {str(spec)[:40]!r}: use a height (a finite number of length units, within +-1e12), auto or none"
        )
    heights = clip.kinematics.p_world_frame @ clip.skeleton.up
    top = float(heights.max()) if clip.n_frames else height
    if height > top:  # no frame could stand on it: a height in another unit, or along another axis
        raise InputError(
            f"--floor {str(spec)[:40]}: the floor would lie above the whole body in every frame (its highest point "
            f"is {top:.4g} length units up); give a height in the clip's length units, auto or none"
        )
    lowest = float(heights.min()) if clip.n_frames else height
    if lowest - height > FAR_BELOW * body.span:  # no contact can rest on it: a typo, or another unit
        log.warning(
            f"--floor {str(spec)[:40]}: the body never comes within {lowest - height:.4g} length units of this "
            f"floor (its lowest point is at {round(lowest, 6) + 0.0:.4g}), so nothing rests on it; give the height "
            "it stands at, auto or none"
        )
    return FloorChoice(height, "given"), True


def reaches(clip: Motion, specs: Sequence[str]) -> tuple[Reach, ...]:
    """The reach tracks of `specs` (SITE=TRACK) over `clip`'s frames."""
    out, given = [], {}
    for spec in specs:
        site, mask, targets = parse_reach_spec(spec, clip.n_frames)
        check_site(clip, site, f"--reach {spec!r}")
        check_reachable(clip.skeleton, targets[mask], clip.skeleton.frame_index(site), f"--reach {spec!r}")
        if site in given and (both := np.flatnonzero(given[site][1] & mask)).size:
            raise InputError(
                f"--reach {spec!r} and --reach {given[site][0]!r} both give {site} a target in frame {both[0]} "
                f"({both.size} frames in all): give each frame one target"
            )
        given[site] = (spec, mask | given.get(site, ("", np.zeros_like(mask)))[1])
        out.append(Reach(site, mask, targets))
    return tuple(out)


def all_contacts(
    clip: Motion,
    body: Body,
    specs: tuple[Sequence[str], Sequence[str]],
    floor: float,
    thresholds: tuple[float | None, float | None],
    paths: Paths | None = None,
) -> Contacts | None:
    """Every contact the (plant_feet, contact) `specs` ask for on `body` (cleanup/body.py; `clip`
    on it, body.on_body), merged on the floor at `floor`; None for none. `thresholds`: (height,
    speed) of detected contacts, None for the defaults; `paths` the clip's on the body
    (ground.body_paths, computed when None)."""
    detect = dict(band=thresholds[0], speed=thresholds[1], paths=paths or body_paths(clip, body))
    parts = [planted_feet(clip, body, floor, specs[0], detect), *body_contacts(clip, body, floor, specs[1], detect)]
    parts = [part for part in parts if part is not None and part.sites]
    return merge_contacts(parts, floor) if parts else None
