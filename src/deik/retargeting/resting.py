"""The source's contacts in a retarget: every mapped point at rest near the floor, and that floor.

Sizes come from the body, never from DOF limits (a rig with position channels on every joint
has limits far wider than the body): every threshold is a fraction of the stature, the vertical
span of the skeleton at rest (keypoints.stature).

- floor: the height the clip rests on, the FLOOR_PERCENTILE-th percentile over the frames in
  which the body's lowest point (any joint or site) is slow of that point's height (a knee
  joint rests a few centimetres above the floor, a toe tip on it; a one-frame dip through the
  floor does not count); a clip that never rests takes its lowest heights;
- a point is slow in frame n when it moves slower than REST_SPEED statures per second, or
  than REST_RATIO times the body's centre (the mean of its joints and sites, no helper or
  carrier: a game rig's fingers pulled it onto the hands): a cartwheel's hands pivot on the
  palms at 0.3-1 m/s while the body turns over them at 1.5-2.5 m/s, and a crawling pelvis 17 cm
  over the floor moves with the body. A clip's first and last frames are as slow as their
  neighbours (cleanup.ground.ends_as_neighbours: a one-sided difference there doubles a
  capture's jitter, and the kick at 120 fps with noise left a resting toe unplanted in its
  first frame, 2.7 mm from the second on human.urdf), and a point is slow through its capture
  noise where `deik clip` finds it so (cleanup.shaking.slow_through_noise, resting speed
  REST_SPEED statures per second and the noise share of the stature): a source shaking at 30 fps
  is not low-passed, and its shake hid the last frame of the shared kick's first rest, where
  the foot then stepped 6 mm on human.urdf; and a rest carries on through the frames at its ends
  that lie where it rested within the noise, as `deik clip`'s do (cleanup.shaking.held_through_noise:
  the kick and the punch at 30 fps with other draws of their noise stepped 17-24 mm a frame there
  on human.urdf, tests/retargeting/test_retarget_noise.py), read on the source as given where it
  was low-passed (`captured`): the filtered source no longer shows the shake, and read on it the
  walk and the kick at 120 fps with noise slid 5.0 and 2.6 mm a frame on human.urdf where the
  filtered heel landed a frame late and the ankle lifted early (`python -m
  benchmarks.retarget_quality`, 0.012 and 0.019 now);
- a point rests near the floor in frame n when it is slow, within REST_BAND statures of its
  own resting height (the RESTING_PERCENTILE-th percentile of its heights over the frames it
  is slow in: a one-frame dip does not lower it), and that resting height is within REST_NEAR
  statures of the floor. Hands, knees, elbows, the back, the pelvis and the head rest as the
  feet do (a cartwheel's wrists 4-6 cm over the floor, the pelvis of a body lying on its back
  14 cm). A walking foot lifts (the band) and a kicking foot flies (the speed); gaps shorter
  than MIN_FRAMES frames are filled (cleanup.contacts), and rests shorter than REST_TIME
  seconds dropped (a sprinting foot rests 0.1 s).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from deik.cleanup.contacts import Contacts, drop_short, fill_gaps, speeds
from deik.cleanup.ground import ends_as_neighbours
from deik.cleanup.shaking import held_through_noise, slow_through_noise
from deik.io.trajectory import Motion
from deik.model.capsules import off_body
from deik.model.kinematics import forward_kinematics

REST_SPEED = 0.1  # statures per second (0.17 m/s on a person)
REST_RATIO = 0.6  # of the body centre's speed
REST_BAND = 0.03  # statures (5 cm) above a point's resting height: a heel raised for push-off lifts
RESTING_PERCENTILE = 10.0
REST_NEAR = 0.09  # statures (15 cm): a joint resting this near the floor touches it (the pelvis lying down)
FLOOR_PERCENTILE = 25.0
REST_TIME = 0.08  # seconds: a shorter rest is a pause in a moving point (a crawling pelvis), not a contact


def _slow(p: np.ndarray, everything: np.ndarray, frame_time: float, size: float, up: np.ndarray) -> np.ndarray:
    """(N, S) bool: the points p (N, S, 3) slower than REST_SPEED x `size` per second or than
    REST_RATIO x the centre of `everything` (N, F, 3), or slow through their capture noise
    (module notes; `up` (3,) the up axis)."""
    centre = speeds(everything.mean(axis=1, keepdims=True), frame_time)
    slow = speeds(p, frame_time) <= np.maximum(REST_SPEED * size, REST_RATIO * centre)
    return ends_as_neighbours(slow | slow_through_noise(p, frame_time, REST_SPEED * size, size, up))


def rest_floor(clip: Motion, size: float) -> float:
    """The height (along up, length units) `clip` rests on (module notes); `size` its stature."""
    sk = clip.skeleton
    body = ~off_body(sk)  # a Reference joint on the ground above the hips and a rig's helper bones are no body
    p = forward_kinematics(sk, clip.frames).p_world_frame[:, body]
    heights = p @ sk.up
    low = p[np.arange(len(p)), heights.argmin(axis=1)]
    slow = _slow(low[:, None], p, clip.frame_time, size, sk.up)[:, 0]
    return float(np.percentile(heights.min(axis=1)[slow] if slow.any() else heights.min(axis=1), FLOOR_PERCENTILE))


def resting_contacts(
    clip: Motion, points: Sequence[str], floor: float, size: float, captured: Motion | None = None
) -> Contacts:
    """Contacts of the joints and sites `points` of `clip` with the floor at height `floor`:
    each point in the frames it rests near the floor (module notes), `size` the stature;
    `captured` the clip as given where `clip` is it low-passed (None: `clip`), on which the
    rests' edges are read through the shake."""
    everything = forward_kinematics(clip.skeleton, clip.frames).p_world_frame
    index = [clip.skeleton.frame_index(name) for name in points]
    p = everything[:, index]
    heights = p @ clip.skeleton.up - floor
    slow = _slow(
        p, everything[:, ~off_body(clip.skeleton)], clip.frame_time, size, clip.skeleton.up
    )  # the body's centre
    resting = np.full(len(points), np.inf)
    for s in np.flatnonzero(slow.any(axis=0)):
        resting[s] = np.percentile(heights[slow[:, s], s], RESTING_PERCENTILE)
    near = resting <= REST_NEAR * size
    low = near & (heights <= resting + REST_BAND * size)
    mask = drop_short(fill_gaps(slow & low))
    shaken = p if captured is None else forward_kinematics(captured.skeleton, captured.frames).p_world_frame[:, index]
    mask = held_through_noise(mask, shaken, low, clip.frame_time, REST_SPEED * size, size, clip.skeleton.up)
    found = Contacts(tuple(points), mask, True, REST_BAND * size, REST_SPEED * size, floor)
    shortest = REST_TIME / clip.frame_time
    for s in range(len(points)):
        for a, b in found.intervals(s):
            if b - a < shortest:
                mask[a:b, s] = False
    return Contacts(tuple(points), mask, True, REST_BAND * size, REST_SPEED * size, floor)
