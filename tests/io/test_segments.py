"""Segment masses: reading JSON segment tables (every error names the file and element) and the
de Leva estimate from bone lengths, checked against two characters with known masses."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import deik
from deik.errors import FileFormatError
from deik.io.bvh import parse_bvh, read_bvh
from deik.io.segments import (
    BONE_CLASSES,
    NOMINAL_MASS,
    bone_class,
    bone_side,
    estimate_segments,
    read_segment_table,
)
from deik.model.build import build_skeleton
from deik.model.joints import Joint, Site, euler
from deik.model.kinematics import forward_kinematics
from helpers import shared_path

JOINTS = ("Hips", "Chest", "RightKnee", "LeftKnee")


def shared(name: str) -> Path:
    return shared_path("humanoid", name)


def table(tmp_path, content) -> Path:
    path = tmp_path / "table.segments.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    return path


def with_segments(skeleton, segments):
    """`skeleton` carrying `segments` instead of its own masses."""
    index = skeleton.joint_names.index
    return dataclasses.replace(
        skeleton,
        mass_joint=np.array([index(s.joint) for s in segments], np.int32),
        mass_offset=np.array([s.com_offset for s in segments]).reshape(-1, 3),
        mass_value=np.array([s.mass for s in segments]),
    )


# --- segment tables ----------------------------------------------------------------------------


@pytest.mark.shared_data
def test_shared_table_is_read_with_its_description():
    path = shared("humanoid3d_walk.segments.json")
    clip = read_bvh(shared("humanoid3d_walk.bvh"))
    segments, description = read_segment_table(path, clip.skeleton.joint_names)
    assert len(segments) == 16 and sum(s.mass for s in segments) == pytest.approx(45.0001)
    assert segments[0].joint == "Hips" and segments[0].com_offset == (0.0, 0.07, 0.0)
    assert segments[0].name == "root" and str(path) in description and "45.0001 kg" in description


def test_a_minimal_table_with_joint_keys_and_a_zero_mass(tmp_path):
    path = table(
        tmp_path,
        {
            "segments": [
                {"joint": "Hips", "mass_kg": 2, "com_offset_m": [0, 1, 0]},
                {"bvh_frame": "Chest", "mass_kg": 0.0, "com_offset_m": [0, 0, 0], "name": "marker"},
            ],
            "comment": "ignored",
        },
    )
    segments, _ = read_segment_table(path, JOINTS)
    assert [(s.joint, s.mass, s.name) for s in segments] == [("Hips", 2.0, ""), ("Chest", 0.0, "marker")]


SEGMENT = {"bvh_frame": "Hips", "mass_kg": 1.0, "com_offset_m": [0, 0, 0]}
BAD_TABLES = {
    "not_json": ('{"segments": [\n  {"bvh_frame": "Hips",,}\n]}', None, 2, r"not valid JSON"),
    "no_segments": ({"links": []}, "segments", None, r'non-empty "segments" list'),
    "not_an_object": ({"segments": [SEGMENT, 3]}, "segments[1]", None, r"must be an object"),
    "no_joint": ({"segments": [{"mass_kg": 1, "com_offset_m": [0, 0, 0]}]}, "segments[0]", None, r"one joint name"),
    "two_joints": ({"segments": [dict(SEGMENT, joint="Chest")]}, "segments[0]", None, r"one joint name"),
    "unknown_joint": (
        {"segments": [SEGMENT, dict(SEGMENT, bvh_frame="RightKne")]},
        "segments[1].bvh_frame",
        None,
        r"unknown joint 'RightKne'; did you mean 'RightKnee'",
    ),
    "missing_mass": (
        {"segments": [{"bvh_frame": "Hips", "com_offset_m": [0, 0, 0]}]},
        "segments[0]",
        None,
        r'needs "mass_kg" and "com_offset_m"',
    ),
    "negative_mass": (
        {"segments": [dict(SEGMENT, mass_kg=-1)]},
        "segments[0].mass_kg",
        None,
        r"must lie between 0 and 1e\+12, got -1",
    ),
    "huge_mass": ({"segments": [dict(SEGMENT, mass_kg=10**400)]}, "segments[0].mass_kg", None, r"finite number"),
    "huge_offset": (
        {"segments": [dict(SEGMENT, com_offset_m=[0, 1e300, 0])]},
        "segments[0].com_offset_m[1]",
        None,
        r"must lie between -1e\+06 and 1e\+06, got 1e\+300",
    ),
    "nan_mass": (
        '{"segments": [{"bvh_frame": "Hips", "mass_kg": NaN, "com_offset_m": [0, 0, 0]}]}',
        "segments[0].mass_kg",
        None,
        r"got nan",
    ),
    "text_mass": ({"segments": [dict(SEGMENT, mass_kg="3")]}, "segments[0].mass_kg", None, r"got '3'"),
    "short_offset": (
        {"segments": [dict(SEGMENT, com_offset_m=[0, 1])]},
        "segments[0].com_offset_m",
        None,
        r"list of 3 finite numbers",
    ),
    "zero_total": ({"segments": [dict(SEGMENT, mass_kg=0)]}, "segments", None, r"add up to 0 kg"),
}


@pytest.mark.parametrize("case", BAD_TABLES)
def test_bad_table_error_names_file_and_element(case, tmp_path):
    content, element, line, message = BAD_TABLES[case]
    path = table(tmp_path, content)
    with pytest.raises(FileFormatError, match=message) as caught:
        read_segment_table(path, JOINTS)
    assert caught.value.source == str(path) and str(caught.value).startswith(str(path))
    assert caught.value.element == element and caught.value.line == line


def test_binary_table(tmp_path):
    path = tmp_path / "table.json"
    path.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(FileFormatError, match="not a text"):
        read_segment_table(path, JOINTS)


LEAVES = (
    st.none()
    | st.booleans()
    | st.floats()
    | st.integers()
    | st.just(10**400)
    | st.text(max_size=8)
    | st.sampled_from(JOINTS)
)
KEYS = st.sampled_from(["segments", "bvh_frame", "joint", "mass_kg", "com_offset_m", "name"])
ENTRY = st.dictionaries(KEYS, LEAVES | st.lists(LEAVES, max_size=4), max_size=5)


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(
    st.recursive(
        LEAVES, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(KEYS, inner, max_size=4), max_leaves=12
    )
    | st.fixed_dictionaries({"segments": st.lists(ENTRY, max_size=4)})
)
def test_any_json_gives_segments_or_a_file_format_error(tmp_path_factory, content):
    path = tmp_path_factory.getbasetemp() / "fuzzed.segments.json"
    path.write_text(json.dumps(content))
    try:
        segments, _ = read_segment_table(path, JOINTS)
    except FileFormatError as error:
        assert error.source == str(path)
        return
    assert sum(s.mass for s in segments) > 0 and all(s.joint in JOINTS for s in segments)


@pytest.mark.shared_data
def test_read_bvh_says_where_masses_came_from():
    estimated = read_bvh(shared("humanoid3d_run.bvh"))
    assert estimated.mass_source.startswith("estimated from bone lengths")
    with_table = read_bvh(shared("humanoid3d_run.bvh"), segments=shared("humanoid3d_run.segments.json"))
    assert with_table.mass_source.startswith("segment table")


@pytest.mark.shared_data
def test_table_errors_surface_from_read_bvh(tmp_path):
    path = table(tmp_path, {"segments": [dict(SEGMENT, bvh_frame="Head")]})
    with pytest.raises(FileFormatError, match=r"unknown joint 'Head'"):
        read_bvh(shared("humanoid3d_run.bvh"), segments=path)


# --- the estimate ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, side, cls",
    [
        ("Hips", "", "trunk"),
        ("RightHip", "right", "thigh"),
        ("LeftUpLeg", "left", "thigh"),
        ("LeftLeg", "left", "shank"),
        ("rShin", "right", "shank"),
        ("L_Foot", "left", "foot"),
        ("LeftToeBase", "left", "foot"),
        ("lShldr", "left", "upper_arm"),
        ("RightArm", "right", "upper_arm"),
        ("LeftForeArm", "left", "forearm"),
        ("hand_r", "right", "hand"),
        ("Spine1", "", "trunk"),
        ("Neck", "", "head"),
        ("Head", "", "head"),
        ("Leg", "", "shank"),
        ("rButtock", "right", None),
        ("Tail", "", None),
    ],
)
def test_bones_are_classified_by_name(name, side, cls):
    assert bone_side(name) == side and bone_class(name) == cls


@pytest.mark.shared_data
def test_estimate_on_the_pybullet_humanoid_is_within_5_cm_of_the_true_com():
    """The pybullet model's masses do not come from de Leva's tables, so the estimate cannot match
    them exactly: it puts more mass high in the trunk and head, which moves the COM up, nearly
    all of the difference vertical: its largest error on each clip lies between 3.4 and 4.5 cm
    (docs/formats.md)."""
    for name in ("walk", "run", "jump"):
        clip = read_bvh(shared(f"humanoid3d_{name}.bvh"))
        truth = json.loads(shared(f"humanoid3d_{name}.segments.json").read_text())
        segments = clip.skeleton.mass_value
        assert (segments > 0).all() and segments.sum() == pytest.approx(NOMINAL_MASS, rel=1e-12)
        com = forward_kinematics(clip.skeleton, clip.frames).p_world_com
        error = np.linalg.norm(com - truth["pybullet_reference"]["com"], axis=1)
        assert 0.0335 <= error.max() < 0.0455, (name, error.max())
        assert "no hand bones" in clip.mass_source and "70 kg nominal" in clip.mass_source


def test_estimate_on_the_built_in_humanoid_is_within_2_cm_of_its_de_leva_com():
    human = deik.humanoid()
    segments, description = estimate_segments(human)
    estimated = with_segments(human, segments)
    poses = np.random.default_rng(0).uniform(human.lower, human.upper, (300, human.n_dofs))
    poses[0] = human.reference
    error = np.linalg.norm(
        forward_kinematics(estimated, poses).p_world_com - forward_kinematics(human, poses).p_world_com, axis=1
    )
    assert error.max() < 0.02  # the estimate from bone lengths, not the exact tables: close, not equal
    assert "unclassified" not in description and "scaled" not in description


def test_unclassified_bones_share_the_rest_by_length():
    joints = [
        Joint("Hips", None, dofs=euler("ZXY")),
        Joint("Spine", "Hips", (0, 0.5, 0)),
        Joint("Tail", "Hips", (0, 0, -0.3)),
        Joint("Antenna", "Spine", (0, 0.1, 0)),
    ]
    sk = build_skeleton(joints, [Site("tip", "Tail", (0, 0, -0.9)), Site("top", "Antenna", (0, 0.3, 0))])
    segments, description = estimate_segments(sk, total_mass=10.0)
    mass = {s.joint: s.mass for s in segments}
    assert sum(mass.values()) == pytest.approx(10.0) and all(m > 0 for m in mass.values())
    assert mass["Tail"] / mass["Antenna"] == pytest.approx(0.9 / 0.3)  # by length
    assert "2 unclassified bones share the remaining" in description
    tail = next(s for s in segments if s.joint == "Tail")
    assert tail.com_offset == pytest.approx((0, 0, -0.45))  # mid-bone


def test_a_skeleton_without_bones_puts_all_mass_at_the_root():
    clip = parse_bvh(
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 1\n5\n", "dot.bvh"
    )
    assert clip.skeleton.total_mass == pytest.approx(NOMINAL_MASS)
    assert "no bone has a length" in clip.mass_source
    assert np.isfinite(forward_kinematics(clip.skeleton, clip.frames).p_world_com).all()


@pytest.mark.parametrize("hands", [False, True])
def test_a_forearm_that_ends_at_the_hand_carries_the_hand(hands):
    """An arm whose forearm bone ends at an End Site for the hand (the shared humanoid's) has the
    hand's de Leva mass on the forearm, its COM where the two together balance, the hand at the
    bone's end; with a hand bone each keeps its own."""
    joints = [Joint("Hips", None, dofs=euler("ZXY")), Joint("Chest", "Hips", (0, 0.5, 0))]
    sites = []
    for side, z in (("Left", 0.2), ("Right", -0.2)):
        joints += [
            Joint(f"{side}Shoulder", "Chest", (0, 0.0, z)),
            Joint(f"{side}Elbow", f"{side}Shoulder", (0, -0.3, 0)),
        ]
        if hands:
            joints.append(Joint(f"{side}Hand", f"{side}Elbow", (0, -0.25, 0)))
            sites.append(Site(f"{side}Hand_end", f"{side}Hand", (0, -0.1, 0)))
        else:
            sites.append(Site(f"{side}Elbow_end", f"{side}Elbow", (0, -0.3, 0)))
    segments, description = estimate_segments(build_skeleton(joints, sites))
    mass = {s.joint: s.mass for s in segments}
    forearm, hand, upper = (BONE_CLASSES[c][0] for c in ("forearm", "hand", "upper_arm"))
    elbow = next(s for s in segments if s.joint == "LeftElbow")
    if hands:
        assert mass["LeftElbow"] / mass["LeftShoulder"] == pytest.approx(forearm / upper)
        assert "on the forearms" not in description
        return
    assert mass["LeftElbow"] / mass["LeftShoulder"] == pytest.approx((forearm + hand) / upper)
    share = (forearm * BONE_CLASSES["forearm"][1] + hand) / (forearm + hand)
    assert elbow.com_offset == pytest.approx((0, -0.3 * share, 0))
    assert "the hands' mass on the forearms" in description


def test_only_the_side_without_a_hand_carries_one():
    """A left hand bone and none on the right: the right forearm carries the hand, the left
    keeps its own share, and the description says the hands' mass went onto forearms."""
    joints = [Joint("Hips", None, dofs=euler("ZXY")), Joint("Chest", "Hips", (0, 0.5, 0))]
    sites = [Site("RightElbow_end", "RightElbow", (0, -0.3, 0)), Site("LeftHand_end", "LeftHand", (0, -0.1, 0))]
    for side, z in (("Left", 0.2), ("Right", -0.2)):
        joints.append(Joint(f"{side}Shoulder", "Chest", (0, 0.0, z)))
        joints.append(Joint(f"{side}Elbow", f"{side}Shoulder", (0, -0.3, 0)))
    joints.append(Joint("LeftHand", "LeftElbow", (0, -0.3, 0)))
    segments, description = estimate_segments(build_skeleton(joints, sites))
    mass = {s.joint: s.mass for s in segments}
    forearm, hand = BONE_CLASSES["forearm"][0], BONE_CLASSES["hand"][0]
    assert mass["RightElbow"] / mass["LeftElbow"] == pytest.approx((forearm + hand) / forearm)
    assert "the hands' mass on the forearms" in description
