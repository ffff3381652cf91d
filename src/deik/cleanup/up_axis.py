"""Whether a clip is read with its file's up: a capture rests on its floor along its up
(floor_it_rests_on), and one read with another up is refused naming the axis it rests along.

A capture rests on its floor (cleanup/ground.py), so in most frames no part of the body lies
far under it, and its body stands over what rests: the centre of its points lies near the
resting points along the ground (the median over the frames in which something rests of
the distance to the nearest; at most 0.12 span on every shared clip, crawls and lying ones
included). A clip read with the wrong up (a BVH made with Z up read as the convention's Y up)
breaks one or the other: in more than SUNK_SHARE of the frames the body's lowest surface lies
more than SUNK x span under the floor detected, or its centre lies more than
OFF_SUPPORT_GIVEN x span from its support. When along another axis direction the body does
rest (sunk in at most a fifth of SUNK_SHARE of the frames) and lies at most half as far (and
OFF_SUPPORT x span; when none does and along its up the body both sinks and lies more than
OFF_SUPPORT from its support, as no capture's body does, the latter only) from its support
(of the four across its up, and upside down only where the rig's rest pose stands that way:
else a clip whose head stays still would look as if it stood on it), the clip is refused,
naming those, most balanced first (a lying body looks alike along several, so deik never
turns a clip's up by itself), rather than fixed against a floor it never stood on. When
along none, the body rests on no one floor (it floats, climbs stairs, or is played in place
with its feet sliding under a fixed root): a sunk body's floor is then its lowest points,
which lift nothing, or the file's ground plane near them (cleanup/ground.py, lowest_points).
The rig's rest pose is evidence too (body.rest_stands_along: the axis along which it stands on
two feet): along that axis a body need only be balanced (OFF_SUPPORT) to be named, and a
clip that passes along its up is still refused when along that axis it rests at most half as
far from its support: a walk made with Z up and read with Y up lies along the floor on its
side, resting there, once its body's feet come from its rest pose stood on them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from deik.cleanup.body import Body, body_of, on_body, rest_stands_along
from deik.cleanup.ground import BAND, FloorChoice, Paths, body_paths, detect_floor, lowest_points, surface_heights
from deik.errors import InputError
from deik.io.trajectory import Motion, Trajectory

SUNK, SUNK_SHARE = 0.05, 0.5  # of the span, of the frames (module notes)
OFF_SUPPORT, OFF_SUPPORT_GIVEN = 0.15, 0.2  # of the span (module notes)


def sunk_share(body: Body, paths: Paths, floor: float) -> float:
    """The share of frames in which the body's lowest surface lies more than SUNK x span under
    `floor` (length units along up)."""
    lowest = surface_heights(body, paths).min(axis=1)
    return float(np.mean(floor - lowest > SUNK * body.span)) if len(lowest) else 0.0


def check_clip_rests(clip: Motion, body: Body) -> None:
    """floor_it_rests_on for `clip` as read on its `body` (body_of), with its paths and floor
    found here: an InputError when its up direction is not its file's, nothing otherwise."""
    motion = on_body(clip, body)
    paths = body_paths(motion, body)
    floor_it_rests_on(clip, body, paths, detect_floor(motion, body, paths))


def floor_it_rests_on(clip: Motion, body: Body, paths: Paths, floor: FloorChoice) -> FloorChoice:
    """The floor `clip` (as read: without its body's sole sites), on its `body` and `paths`,
    rests on along its skeleton's up: the `floor` detected when it rests there; when it does
    not but does along another axis direction, an InputError naming those (its file's up is
    another); when it rests along none, the lowest points (module notes)."""
    share, off = sunk_share(body, paths, floor.height), off_support(body, paths, floor.height)
    sk = clip.skeleton
    if share <= SUNK_SHARE and off <= OFF_SUPPORT_GIVEN:
        _check_rest_up(clip, off)
        return floor
    rests = []  # (how far the body's centre lies from its support, axis) of the axes it rests along
    own = rest_stands_along(clip)
    for axis in np.vstack([np.eye(3), -np.eye(3)]):
        # not its up, nor upside down (a still head looks like a foot) unless its rest pose stands that way
        flipped = own is not None and axis @ sk.up <= -0.999 and np.dot(own, axis) >= 0.999
        if abs(axis @ sk.up) < 0.999 or flipped:
            turned = Trajectory(replace(sk, up=axis), clip.frames, clip.frame_time, clip.source)
            turned_body = body_of(turned)
            turned_paths = body_paths(on_body(turned, turned_body), turned_body)
            level = detect_floor(turned, turned_body, turned_paths).height
            if sunk_share(turned_body, turned_paths, level) <= SUNK_SHARE / 5:
                rests.append((off_support(turned_body, turned_paths, level), tuple(axis)))

    def limit(axis) -> float:  # along the axis the rest pose stands on two feet, balanced is enough
        return OFF_SUPPORT if own is not None and np.dot(own, axis) >= 0.999 else min(OFF_SUPPORT, off / 2)

    rests.sort()
    balanced = [_words(axis) for away, axis in rests if away <= limit(axis)]
    if not balanced and share > SUNK_SHARE and off > OFF_SUPPORT:  # sunk and off its support along its up
        # as no capture's body is: along another axis, balanced is enough
        balanced = [_words(axis) for away, axis in rests if away <= OFF_SUPPORT]
    if not balanced:  # no better along any other axis: a floating body, stairs, a clip played in place
        return floor if share <= SUNK_SHARE else lowest_points(body, paths)
    if len(balanced) == 1:
        hint = f"it rests along {balanced[0]}: give --up {balanced[0]}"
    else:
        hint = (
            f"it may rest along {', '.join(balanced[:-1])} or {balanced[-1]} (a lying body looks alike along "
            "several): give --up with the one that was up in the capture"
        )
    up = f"along up {_words(sk.up)}"
    why = (
        f"in {share:.0%} of the frames the body lies more than {SUNK * body.span:.3g} length units under the floor "
        f"its resting points sit on ({floor.height:.4g} {up})"
        if share > SUNK_SHARE
        else f"its centre lies {off:.2g} of its span along the ground from what rests on the floor {up}, as no body "
        "standing under gravity does"
    )
    raise InputError(f"{clip.source or 'the clip'}: {why}, so that is not its up direction; {hint}")


def _rests_along(clip: Motion, axis: np.ndarray) -> float | None:
    """How far (off_support) `clip`'s body lies from its support with `axis` (3,) as up, when it
    rests along it (sunk in at most a fifth of SUNK_SHARE of the frames); None otherwise."""
    turned = Trajectory(replace(clip.skeleton, up=axis), clip.frames, clip.frame_time, clip.source)
    body = body_of(turned)
    paths = body_paths(on_body(turned, body), body)
    level = detect_floor(turned, body, paths).height
    return off_support(body, paths, level) if sunk_share(body, paths, level) <= SUNK_SHARE / 5 else None


def _check_rest_up(clip: Motion, off: float) -> None:
    """InputError when `clip` rests along its up with its body `off` (off_support) its support,
    but its rest pose stands on two feet along another axis (body.rest_stands_along) along which
    it rests at most half as far off: a file made with Z up and read with Y up, whose walk then
    looks like a body lying along the floor, resting on its side (module notes). A body that
    lies still in the capture rests alike along both and is kept."""
    sk = clip.skeleton
    axis = rest_stands_along(clip)
    if axis is None or abs(axis @ sk.up) >= 0.999:
        return
    away = _rests_along(clip, axis)
    if away is not None and away <= min(OFF_SUPPORT, off / 2):
        words = _words(np.round(axis, 6))
        raise InputError(
            f"{clip.source or 'the clip'}: its rest pose stands on two feet along {words}, where its centre lies "
            f"{away:.2g} of its span from what rests, against {off:.2g} along up {_words(sk.up)}, so that is not "
            f"its up direction; it rests along {words}: give --up {words}"
        )


def off_support(body: Body, paths: Paths, floor: float) -> float:
    """The median, over the frames in which part of the body rests near `floor`, of how far
    (along the ground, as a share of the span) the centre of its points lies from the nearest
    resting point: small when the body stands on what rests, as a body under gravity does; inf
    when nothing rests."""
    up = body.skeleton.up
    resting = paths.slow & body.part & (surface_heights(body, paths) <= floor + BAND * body.span)
    offset = paths.positions - paths.positions[:, body.own].mean(axis=1, keepdims=True)
    along = np.linalg.norm(offset - (offset @ up)[..., None] * up, axis=-1)
    away = np.where(resting, along, np.inf).min(axis=1)[resting.any(axis=1)]
    return float(np.median(away)) / body.span if away.size else np.inf


def _words(vector: np.ndarray) -> str:
    """A direction as the words of --up, e.g. "0 0 1"."""
    return " ".join(f"{value:g}" for value in np.asarray(vector, float) + 0.0)
