"""Where each contact plants: one target per contact interval of each site (planted_targets).

A plant is the site's median position along the ground over its interval in the capture (the
frames it rests in outweigh a fast first or last one) at the median of its heights there (a
one-frame dip does not lower it), raised where the site or a site rigidly linked to it sank
through the floor (a leg made longer); "the floor" of a site is the floor's height plus the
site's clearance (how far above it a knee joint sits when the knee touches, Contacts.clearance).
A plant within SNAP_FRACTION x reach above the floor is put on it when the site has no
clearance (a sole, a toe tip); one with a clearance stays where the capture rests it, since a
clearance is an estimate and lowering a hand onto a guessed radius could push the real hand
into the floor. Rests of one site a move apart (the gap between them at most GAP seconds, as
cleanup/ground.py keeps only where the point moves across it: a toe shuffling or swivelling
while its heel rests) plant the capture's move apart (_moved_plants): each rest's median alone
puts the plants of a creeping point farther apart than it moves across the gap, and the move
between them is faster than the capture's (the shared punch's front toe moved 29 mm over two
frames between its plants where the capture moves 19, and its rest before the move was lost).
Plants of two rigidly linked sites (an ankle and its toe; a toe tip whose distance from the heel
a bending toe changes by less than RIGID_TOLERANCE x reach: rigid_pairs) are then placed
relative to each other (_linked_plants), so both can be met at once: a whole foot that
shuffles (heel and toe across the same gap) is still held where it first rested, as a foot
rolling from heel to toe.
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.contacts import Contacts, site_positions, true_runs
from deik.cleanup.ground import GAP
from deik.errors import InputError
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach

RIGID_TOLERANCE = 5e-3  # of reach: sites whose distance varies less are rigidly linked
SNAP_FRACTION = 0.01  # of reach: a plant without clearance this close to the floor is put on it
HANDOVER = 3  # frames: a plant starting this soon after a rigidly linked site's ends takes over from it


def rigid_pairs(p: np.ndarray, reach: float, resting: np.ndarray) -> list[tuple[int, int, float]]:
    """(s, t, distance) of the sites whose distance at positions `p` (N, S, 3) stays the same in
    every frame, to within RIGID_TOLERANCE x `reach` (an ankle and its toe, moved by no DOF
    between them or by a toe joint that bends a little), with their mean distance in the
    frames both rest (`resting` (N, S) bool; in every frame where they never rest together),
    where their plants must lie that far apart. At 1e-6 of reach, a toe the capture bends 5
    degrees unlinked its heel, and the two plants, placed alone, could not both be met: the
    shared dance on a rig whose toes bend so slid 6.7 mm a frame."""
    pairs = []
    for s in range(p.shape[1]):
        for t in range(s + 1, p.shape[1]):
            distance = np.linalg.norm(p[:, s] - p[:, t], axis=-1)
            if np.ptp(distance) <= RIGID_TOLERANCE * reach:
                both = resting[:, s] & resting[:, t]
                pairs.append((s, t, float(distance[both if both.any() else slice(None)].mean())))
    return pairs


def _at_distance(point: np.ndarray, anchor: np.ndarray, distance: float, up: np.ndarray) -> np.ndarray:
    """`point` (..., 3) moved to lie `distance` from `anchor` (..., 3): along the ground, keeping
    its height, when their heights differ by less than `distance`, else along the line between
    them; unchanged when they coincide (no direction to move in)."""
    delta = point - anchor
    rise = delta @ up
    flat = delta - rise[..., None] * up
    flat_length, length = np.linalg.norm(flat, axis=-1), np.linalg.norm(delta, axis=-1)
    along = (np.abs(rise) < distance) & (flat_length > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ground = anchor + rise[..., None] * up + flat * (np.sqrt(distance**2 - rise**2) / flat_length)[..., None]
        line = anchor + delta * (distance / length)[..., None]
    return np.where(along[..., None], ground, np.where((length > 0)[..., None], line, point))


def _links(plants: dict, pairs, p: np.ndarray, up: np.ndarray) -> dict:
    """{plant: [(other plant, place)]}: how each plant of a rigidly linked site (`pairs`) is put
    relative to the other's, place(anchor) -> target (3,). Overlapping intervals: their
    distance apart (_at_distance). Intervals that hand over (one starts at most HANDOVER frames
    after the other stops, a heel lifting as the toe lands): the capture's offset between the
    two at the handover, along the ground (each keeps its height), so the foot does not jump
    where one plant ends and the other begins. `p` (N, S, 3): the sites' capture positions."""
    links = {key: [] for key in plants}
    for s, t, distance in pairs:
        for first in [key for key in plants if key[0] == s]:
            for second in [key for key in plants if key[0] == t]:
                if max(first[1], second[1]) < min(first[2], second[2]):
                    links[first].append((second, lambda a, key=second, d=distance: _at_distance(plants[key], a, d, up)))
                    links[second].append((first, lambda a, key=first, d=distance: _at_distance(plants[key], a, d, up)))
                    continue
                for early, late in ((first, second), (second, first)):
                    if 0 <= late[1] - early[2] < HANDOVER:
                        offset = p[early[2] - 1, late[0]] - p[early[2] - 1, early[0]]
                        offset -= (offset @ up) * up
                        for key, other, sign in ((late, early, 1.0), (early, late, -1.0)):
                            links[other].append(
                                (key, lambda anchor, key=key, o=sign * offset: _on_level(anchor + o, plants[key], up))
                            )
    return links


def _on_level(point: np.ndarray, height_of: np.ndarray, up: np.ndarray) -> np.ndarray:
    """`point` (3,) at the height of `height_of` (3,) along up."""
    return point + ((height_of - point) @ up) * up


def _linked_plants(plants: dict, pairs, p: np.ndarray, up: np.ndarray) -> dict:
    """`plants` {(site, start, stop): target (3,)} with the plants of two rigidly linked sites
    (`pairs`) placed relative to each other (_links). Linked plants form groups (a toe planted
    through two plants of its ankle, a heel lifting and landing again): each group's longest
    plant stays, and the others are placed in turn relative to the one placed before them they
    are linked to, so every link of a chain holds; a link closing a loop holds only
    approximately."""
    links = _links(plants, pairs, p, up)
    out = dict(plants)
    placed = set()
    for root in sorted(plants, key=lambda key: (key[1] - key[2], key[1], key[0])):  # longest first
        if root in placed:
            continue
        placed.add(root)
        queue = [root]
        while queue:
            anchor = queue.pop(0)
            for key, place in links[anchor]:
                if key not in placed:
                    out[key] = place(out[anchor])
                    placed.add(key)
                    queue.append(key)
    return out


def lifted_heights(
    heights: np.ndarray, mask: np.ndarray, pairs: list[tuple[int, int, float]], floor: np.ndarray
) -> np.ndarray:
    """(N, S) heights of the contact sites, each frame's raised by the depth below its `floor`
    ((S,) or (N, S)) of the deepest of the site and the sites rigidly linked to it (`pairs`) in
    contact then (or moving between two of its contacts while the site rests: _between): a foot
    sunk through the floor (legs made longer) plants its ankle as high above the floor as its
    toe is above the sole."""
    sunk = np.maximum(floor - heights, 0.0)
    lift = np.where(mask, sunk, 0.0)
    for s, t, _ in pairs:
        lift[:, s] = np.maximum(lift[:, s], np.where(mask[:, t] | _between(mask[:, s], mask[:, t]), sunk[:, t], 0.0))
        lift[:, t] = np.maximum(lift[:, t], np.where(mask[:, s] | _between(mask[:, t], mask[:, s]), sunk[:, s], 0.0))
    return heights + lift


def _between(holder: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(N,) bool: the frames of each run of `holder` (N,) bool from the first to the last frame of
    `other` (N,) bool in it. A toe that moves between two of its rests (ground.py: a move)
    while its heel rests stays on the floor with the heel, sunk as deep: lifting the heel by
    the toe's depth only while the toe rests dropped it 27 mm for the one frame of the move
    (the shared punch with longer legs), a jolt."""
    out = np.zeros(len(holder), bool)
    for a, b in true_runs(holder):
        inside = np.flatnonzero(other[a:b])
        if inside.size:
            out[a + inside[0] : a + inside[-1] + 1] = True
    return out


def _moved_plants(plants: dict, site: int, spans, p: np.ndarray, up: np.ndarray, gap: int, along: str) -> dict:
    """`plants` {(site, start, stop): target (3,)} with those of `site`, whose contact intervals
    are `spans` [(start, stop)] in order, placed the capture's move apart along the ground in
    each chain of intervals at most `gap` frames apart (a move), from the last frame of one to
    the first of the next: the chain's first plant is the median (`along` "median") or mean
    ("mean") of the capture positions `p` (N, 3) of every interval less its offset from the
    first, so every rest counts as it would alone; each plant keeps its own height."""
    out = dict(plants)
    chains = [[span] for span in spans[:1]]
    for (_, stop), (start, end) in zip(spans, spans[1:]):
        if start - stop <= gap:
            chains[-1].append((start, end))
        else:
            chains.append([(start, end)])
    centre = np.median if along == "median" else np.mean
    for chain in (chain for chain in chains if len(chain) > 1):
        offsets = [np.zeros(3)]
        for (_, stop), (start, _) in zip(chain, chain[1:]):
            move = p[start] - p[stop - 1]
            offsets.append(offsets[-1] + move - (move @ up) * up)
        first = centre(np.concatenate([p[a:b] - offset for (a, b), offset in zip(chain, offsets)]), axis=0)
        for (a, b), offset in zip(chain, offsets):
            out[site, a, b] = _on_level(first + offset, plants[site, a, b], up)
    return out


def linked_at_heights(
    targets: np.ndarray, mask: np.ndarray, pairs: list[tuple[int, int, float]], up: np.ndarray
) -> np.ndarray:
    """`targets` (N, S, 3) (each site's plant in the frames of `mask` (N, S) bool, heights as a
    fix holds them) with, in every frame both sites of a rigidly linked pair (`pairs`,
    rigid_pairs) are planted, the one of the shorter run moved along the ground to lie their
    distance apart from the other (_at_distance): a foot tipped by lifting its sole out of the
    floor spans less ground between its heel and toe than in the capture, and plants left the
    capture's span apart could not both be met (the shared walk standing still 12 mm deep:
    3 mm apart, every frame of the stand unmet)."""
    out = np.array(targets, float, copy=True)
    run_length = np.zeros(mask.shape)
    for s in range(mask.shape[1]):
        for a, b in true_runs(mask[:, s]):
            run_length[a:b, s] = b - a
    for s, t, distance in pairs:
        both = mask[:, s] & mask[:, t]
        for keep, move, moves in (
            (s, t, run_length[:, s] >= run_length[:, t]),
            (t, s, run_length[:, s] < run_length[:, t]),
        ):
            frames = both & moves
            out[frames, move] = _at_distance(out[frames, move], out[frames, keep], distance, up)
    return out


def planted_targets(clip: Motion, contacts: Contacts, along: str = "median") -> np.ndarray:
    """Where each site should stay planted: (N, S, 3) length units, NaN outside contacts.

    Per contact interval, the median (`along` "median") or mean ("mean") world position of the
    site over the interval in `clip` (the original), at the median of its heights along up there
    (a one-frame dip does not lower it), each frame's height first raised by how far the site or
    a site rigidly linked to it is below its floor (`contacts.ground` plus its clearance); a
    height within SNAP_FRACTION x reach of the floor is put on it when the site has no
    clearance. Two sites a fixed distance apart (an ankle and its toe) whose intervals overlap
    get targets that distance apart (_linked_plants), so both can be met at once. A site's
    intervals at most GAP seconds apart (a move) plant the capture's move apart (module notes).
    """
    if contacts.mask.shape[0] != clip.n_frames:
        raise InputError(f"contacts cover {contacts.mask.shape[0]} frames, the clip has {clip.n_frames}")
    up = clip.skeleton.up
    p = site_positions(clip, contacts.sites)
    pairs = rigid_pairs(p, body_reach(clip.skeleton), contacts.mask)
    floor = contacts.ground + contacts.clearance
    heights = lifted_heights(p @ up, contacts.mask, pairs, floor)
    plants = {}  # (site, start, stop) -> target (3,)
    for s in range(len(contacts.sites)):
        for a, b in contacts.intervals(s):
            mean = np.median(p[a:b, s], axis=0) if along == "median" else p[a:b, s].mean(axis=0)
            height = max(float(np.median(heights[a:b, s])), floor[s])
            if contacts.clearance[s] == 0 and height - floor[s] <= SNAP_FRACTION * body_reach(clip.skeleton):
                height = floor[s]
            plants[s, a, b] = mean + (height - mean @ up) * up
    gap = max(1, int(round(GAP / clip.frame_time)))
    for s in range(len(contacts.sites)):
        plants = _moved_plants(plants, s, contacts.intervals(s), p[:, s], up, gap, along)
    plants = _linked_plants(plants, pairs, p, up)
    targets = np.full(p.shape, np.nan)
    for (s, a, b), target in plants.items():
        targets[a:b, s] = target
    return targets
