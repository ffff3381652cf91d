"""How fix_clip takes a DE pass's repairs on a procedural leg and arm: only the change a repair
makes is eased into its neighbours (frames no search touches keep the warm start's correction),
and a repair that turns a joint far from the pose it repairs is refused even where the frame
already jolted."""

import numpy as np

from deik.cleanup.body import body_of
from deik.cleanup.clip_goals import ClipGoals
from deik.cleanup.fix import _without_jolts
from deik.io.bvh import Clip
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, euler, translation

N, DT = 90, 1 / 60
HIP, KNEE, ARM = 3, 4, 5  # DOFs after the root's three translations


def leg_and_arm() -> Clip:
    """A hip carrying a thigh, shin and toe and an arm with a hand, swinging at 1 Hz."""
    joints = [
        Joint("hips", None, dofs=translation("XYZ")),
        Joint("thigh", "hips", dofs=euler("Z")),
        Joint("shin", "thigh", (0.0, -0.45, 0.0), dofs=euler("Z")),
        Joint("arm", "hips", (0.0, 0.5, 0.0), dofs=euler("Z")),
    ]
    sites = [Site("toe", "shin", (0.1, -0.45, 0.0)), Site("hand", "arm", (0.0, -0.6, 0.0))]
    t = np.arange(N) * DT
    poses = np.zeros((N, 6))
    poses[:, 1] = 0.9 + 0.05 * np.sin(2 * np.pi * t)
    poses[:, HIP] = 0.4 * np.sin(2 * np.pi * t)
    poses[:, KNEE] = 0.3 + 0.3 * np.sin(2 * np.pi * t + 1.0)
    poses[:, ARM] = 0.3 * np.sin(2 * np.pi * t + 2.0)
    return Clip.from_poses(build_skeleton(joints, sites), poses, DT)


def bump(first: int, last: int, height: float) -> np.ndarray:
    """(N,) a smooth bump of `height` over frames first..last, zero outside."""
    n = np.arange(N)
    inside = (n >= first) & (n <= last)
    return np.where(inside, height * np.sin(np.pi * (n - first) / (last - first)) ** 2, 0.0)


def test_a_repair_eases_only_its_change_and_keeps_the_corrections_of_frames_no_search_touches():
    """The leg is searched while it touches (frames 0-19 and 45-89), nothing in the flight
    between; the warm start bent the knee 3 degrees into the landing (frames 30-60). A DE repair
    of frames 60-74 bends it 0.1 degree more: taken whole, and every frame outside them keeps the
    warm start's displacement (easing the whole displacement again would fade the flight's
    correction towards the capture)."""
    clip = leg_and_arm()
    searched = np.zeros((N, 6), bool)
    searched[:20, : KNEE + 1] = searched[45:, : KNEE + 1] = True
    warm = np.zeros((N, 6))
    warm[:, KNEE] = bump(30, 60, np.radians(3.0))
    repaired = (np.arange(N) >= 60) & (np.arange(N) <= 74)
    found = warm.copy()
    found[:, KNEE] += bump(59, 75, np.radians(0.1))
    taken, refused = _without_jolts(clip, warm, found, repaired, searched, body_of(clip), ClipGoals(floor=0.0))
    assert refused == 0
    np.testing.assert_allclose(taken[repaired], found[repaired], atol=1e-12)
    np.testing.assert_allclose(taken[~repaired], warm[~repaired], atol=1e-12)


def test_a_repair_that_turns_a_joint_far_from_the_pose_it_repairs_is_refused():
    """The warm start already turned the arm 40 degrees from the capture over frames 10-80 (each
    a jolted frame: a joint over 30 degrees from the capture); a repair of frames 40-44 that
    swings it 150 degrees further is refused and the clip stays as it was."""
    clip = leg_and_arm()
    searched = np.ones((N, 6), bool)
    warm = np.zeros((N, 6))
    warm[:, ARM] = np.where((np.arange(N) >= 10) & (np.arange(N) <= 80), np.radians(40.0), 0.0)
    warm[:, ARM] = np.convolve(warm[:, ARM], np.ones(9) / 9, mode="same")  # eased in and out
    repaired = (np.arange(N) >= 40) & (np.arange(N) <= 44)
    found = warm.copy()
    found[repaired, ARM] += np.radians(150.0)
    taken, refused = _without_jolts(clip, warm, found, repaired, searched, body_of(clip), ClipGoals(floor=0.0))
    assert refused == repaired.sum()
    np.testing.assert_array_equal(taken, warm)
