"""A capture that stands still with its feet in the floor: a heel and toe planted together are
kept their distance apart at the heights the fix lifts them to (cleanup/plants.linked_at_heights)."""

import dataclasses

import numpy as np
import pytest

from deik.cleanup.clean import CleanOptions, clean_clip
from deik.cleanup.plants import linked_at_heights
from deik.io.bvh import parse_bvh
from helpers import shared_path
from judging.cases import source_case
from judging.rigs import format_rig

UP = np.array([0.0, 1.0, 0.0])


def test_a_linked_plant_lifted_out_of_level_keeps_its_distance_and_the_longer_plant_stays():
    N = 10
    heel, toe = np.array([0.0, 0.0, 0.0]), np.array([0.2, 0.0, 0.0])  # 0.2 apart on the capture's level floor
    targets = np.zeros((N, 2, 3))
    targets[:, 0], targets[:, 1] = heel, toe
    targets[:, 1, 1] = np.linspace(0.0, 0.05, N)  # the fix holds the toe higher and higher
    mask = np.zeros((N, 2), bool)
    mask[:, 0] = True  # the heel planted all 10 frames
    mask[2:7, 1] = True  # the toe in frames 2-6
    out = linked_at_heights(targets, mask, [(0, 1, 0.2)], UP)
    np.testing.assert_array_equal(out[:, 0], targets[:, 0])  # the longer plant stays
    apart = np.linalg.norm(out[:, 1] - out[:, 0], axis=1)
    np.testing.assert_allclose(apart[2:7], 0.2)
    np.testing.assert_allclose(out[:, 1, 1], targets[:, 1, 1])  # heights kept
    np.testing.assert_allclose(out[2:7, 1, 0], np.sqrt(0.2**2 - targets[2:7, 1, 1] ** 2))  # moved along the ground
    np.testing.assert_array_equal(out[~mask[:, 1], 1], targets[~mask[:, 1], 1])  # unplanted frames untouched


@pytest.mark.shared_data
@pytest.mark.parametrize(("name", "most_unmet"), [("walk", 0.05), ("run", 0.05)])
def test_a_capture_standing_still_in_the_floor_meets_its_contacts_while_it_stands(name, most_unmet):
    """The shared clip's first and last poses held 2 s each, the whole body 12 mm lower: the
    standing feet sink and are lifted out, tipping; their heel and toe plants, left their
    capture span apart, could not both be met in almost any frame of the stand (98 % of the
    walk's standing frames unmet, every one of the run's; none now, the warm start run again on
    plants moved to fit the tipped feet: with those plants for DE alone, 23 % of the walk's)."""
    case = source_case(shared_path("humanoid", f"humanoid3d_{name}.bvh"))
    rig = case.rig
    hold = int(round(2.0 / rig.frame_time))
    frames = np.concatenate([np.repeat(rig.frames[:1], hold, 0), rig.frames, np.repeat(rig.frames[-1:], hold, 0)])
    root_y = next(k for k, (j, c) in enumerate(rig.columns) if j == 0 and c == "Yposition")
    frames[:, root_y] -= 0.012
    clip = parse_bvh(format_rig(dataclasses.replace(rig, frames=frames)), f"{name}_stand.bvh")
    cleaned = clean_clip(clip, CleanOptions())
    standing = np.r_[0:hold, len(frames) - hold : len(frames)]
    unmet = np.isin(standing, cleaned.unmet_frames)
    assert unmet.mean() <= most_unmet, np.flatnonzero(unmet)
