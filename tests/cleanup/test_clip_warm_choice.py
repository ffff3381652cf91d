"""Which warm start a clip fix keeps (warm_tries.calmed_warm_start): of the floor lifted along
envelopes, lifted whole bone by bone, or the plain floor, the one with the most frames on the
floor, then the most meeting every goal; never one that meets fewer frames than another and turns
a joint more than FAR_DEGREES from the capture in FAR_SHARE more of the frames. One frame left
out of the shared get-up (a capture hiccup at frame 135) gave the whole-bone lift 155 frames on
the floor against the plain floor's 146: it was kept though it met 105 frames against 141 and
turned a joint past 30 degrees in 46 frames against none (a shoulder 95 degrees off; 92 frames
met in the end against 117 without the hiccup)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import deik


@pytest.mark.shared_data
def test_one_frame_left_out_changes_neither_the_choice_nor_the_motion(shared_data):
    clip = deik.read_bvh(shared_data / "humanoid" / "humanoid3d_getup_facedown.bvh")
    hiccup = dataclasses.replace(clip, frames=np.delete(clip.frames, 135, axis=0))
    whole, dropped = deik.clean_clip(clip).report, deik.clean_clip(hiccup).report
    assert not dropped["joints_far_from_capture"]["joint_frames"]  # no joint turned past FAR_DEGREES
    assert dropped["frames_met"] >= whole["frames_met"] - 3, (dropped["frames_met"], whole["frames_met"])
