"""URDF values read strictly: every malformed number, vector, mass, limit or mimic names the
file, the line of the element at fault, the link or joint and the fix; spec defaults for an
omitted <origin>/<axis>; CR-only line endings; entity declarations refused; nothing printed."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deik.errors import FileFormatError
from deik.io.urdf import read_urdf

# line 1: XML declaration, 2: <robot>, 3: links, 4: <joint ...>, 5: <parent>, 6: <origin>, 7: <axis>, 8: <limit>
JOINT = (
    '<joint name="j" type="revolute">\n<parent link="a"/><child link="b"/>\n<origin xyz="0 0 1" rpy="0 0 0"/>\n'
    '<axis xyz="0 0 1"/>\n<limit lower="-1" upper="1"/>\n</joint>'
)
LINKS = '<link name="a"><inertial><origin xyz="0 0 0.5"/><mass value="2"/></inertial></link><link name="b"/>'


def _robot(joint: str = JOINT, links: str = LINKS) -> str:
    return f'<?xml version="1.0"?>\n<robot name="r">\n{links}\n{joint}\n</robot>\n'


def _read(tmp_path, text: str, name: str = "bad.urdf"):
    path = tmp_path / name
    path.write_bytes(text.encode())
    return read_urdf(path)


def _joint(old: str, new: str) -> str:
    assert old in JOINT
    return _robot(JOINT.replace(old, new))


def _mass(value: str) -> str:
    return _robot(links=LINKS.replace('value="2"', value))


# 10**9 letters once expanded
BILLION_LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE robot [\n<!ENTITY a "aaaaaaaaaa">\n'
    + "".join(f'<!ENTITY {b} "{("&" + a + ";") * 10}">\n' for a, b in zip("abcdefgh", "bcdefghi"))
    + ']>\n<robot name="&i;"><link name="a"/></robot>\n'
)
BAD = {
    "underscore": (
        _joint('upper="1"', 'upper="1_000"'),
        r"bad\.urdf:8: joint 'j': <limit upper=\"1_000\">: '1_000' is not a plain decimal number; write",
    ),
    "hexadecimal": (_joint('lower="-1"', 'lower="0x10"'), r"bad\.urdf:8: joint 'j': .*'0x10' is not a plain decimal"),
    "bare exponent": (_joint('xyz="0 0 1" rpy', 'xyz="0 e5 1" rpy'), r"bad\.urdf:6: joint 'j': .*'e5' is not a plain"),
    "nan limit": (_joint('upper="1"', 'upper="nan"'), r"bad\.urdf:8: joint 'j': .*'nan' is not a plain decimal"),
    "infinite limit": (_joint('lower="-1"', 'lower="-inf"'), r"bad\.urdf:8: .*'-inf' is not a plain decimal"),
    "overflowing limit": (_joint('upper="1"', 'upper="1e999"'), r"bad\.urdf:8: .*1e999 is too large for a 64-bit"),
    "empty limit": (_joint('lower="-1"', 'lower=""'), r"bad\.urdf:8: .*<limit lower=\"\"> holds 0 numbers; write one"),
    "rpy of 4": (_joint('rpy="0 0 0"', 'rpy="0 0 0 1"'), r"bad\.urdf:6: .*<origin rpy=\"0 0 0 1\"> holds 4 numbers"),
    "xyz of 2": (_joint('xyz="0 0 1" rpy', 'xyz="0 1" rpy'), r"bad\.urdf:6: .*holds 2 numbers; write 3 numbers"),
    "axis of 2": (_joint('<axis xyz="0 0 1"/>', '<axis xyz="0 1"/>'), r"bad\.urdf:7: joint 'j': <axis xyz=\"0 1\">"),
    "two origins": (_joint("<axis", '<origin xyz="1 0 0"/><axis'), r"bad\.urdf:7: joint 'j': has 2 <origin> elements"),
    "no type": (_joint(' type="revolute"', ""), r"bad\.urdf:4: joint 'j': needs a type attribute"),
    "nameless mimic": (_joint("</joint>", '<mimic multiplier="2"/></joint>'), r"bad\.urdf:9: .*<mimic> needs joint="),
    "mimic of fixed": (
        _robot(
            JOINT.replace("</joint>", '<mimic joint="k"/></joint>') + '<joint name="k" type="fixed">'
            '<parent link="b"/><child link="c"/></joint>',
            LINKS + '<link name="c"/>',
        ),
        r"bad\.urdf:4: joint 'j': mimics 'k', a fixed joint; a mimic must follow",
    ),
    "bad multiplier": (_joint("</joint>", '<mimic joint="j" multiplier="2x"/></joint>'), r"'2x' is not a plain"),
    "nan mass": (_mass('value="nan"'), r"bad\.urdf:3: link 'a': <mass value=\"nan\">: 'nan' is not a plain decimal"),
    "infinite mass": (_mass('value="1e400"'), r"bad\.urdf:3: link 'a': .*1e400 is too large for a 64-bit float"),
    "huge mass": (_mass('value="1e13"'), r"bad\.urdf:3: link 'a': mass 1e\+13 kg is above the 1e\+12 kg"),
    "mass without value": (_mass(""), r"bad\.urdf:3: link 'a': <mass> needs value="),
    "bad inertial origin": (
        _robot(links=LINKS.replace('xyz="0 0 0.5"', 'xyz="0 0 0.5" rpy="1,2,3"')),
        r"bad\.urdf:3: link 'a': <origin rpy=\"1,2,3\"> holds 1 numbers",
    ),
    "billion laughs": (BILLION_LAUGHS, r"bad\.urdf:3: the <!DOCTYPE> declares entities .* remove the DOCTYPE"),
    "external entity": (
        (
            '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
            '<robot name="r"><link name="&x;"/></robot>\n'
        ),
        r"bad\.urdf:2: the <!DOCTYPE> declares entities",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_value_names_the_file_line_element_and_fix(tmp_path, case):
    text, message = BAD[case]
    with pytest.raises(FileFormatError, match=message):
        _read(tmp_path, text)


def test_cr_only_line_endings_give_the_right_line(tmp_path):
    text = _joint('upper="1"', 'upper="1_000"').replace("\n", "\r")
    with pytest.raises(FileFormatError, match=r"bad\.urdf:8: joint 'j': <limit upper"):
        _read(tmp_path, text)


@pytest.mark.parametrize(
    "form,change",
    [
        ("NUL padding", lambda t: t + "\0\0\0"),
        ("blank lines first", lambda t: "\n\n  \n" + t),
        ("byte-order mark", lambda t: "\ufeff" + t),
        ("version 0.0", lambda t: t.replace('version="1.0"', "version='0.0' encoding='utf-8'")),
        ("version 1.1 after blank lines", lambda t: "\n " + t.replace('version="1.0"', 'version="1.1"')),
    ],
)
def test_what_other_urdf_readers_take_is_read_with_its_lines(tmp_path, form, change):
    """pybullet's and ROS's readers take these; deik reads the robot alike, and an error names
    the line the file has (blank lines before the declaration count)."""
    reference = _read(tmp_path, _robot(), "plain.urdf")
    skeleton = _read(tmp_path, change(_robot()), "other.urdf")
    np.testing.assert_array_equal(skeleton.offsets, reference.offsets)
    np.testing.assert_array_equal(skeleton.mass_offset, reference.mass_offset)
    bad = change(_joint('upper="1"', 'upper="1_000"'))
    line = 8 + bad[: bad.index("<?xml")].count("\n")
    with pytest.raises(FileFormatError, match=rf"bad\.urdf:{line}: joint 'j': <limit upper"):
        _read(tmp_path, bad)


def test_cr_only_and_crlf_files_read_like_lf_files(tmp_path):
    reference = _read(tmp_path, _robot(), "lf.urdf")
    for name, ending in (("cr.urdf", "\r"), ("crlf.urdf", "\r\n")):
        skeleton = _read(tmp_path, _robot().replace("\n", ending), name)
        np.testing.assert_array_equal(skeleton.offsets, reference.offsets)
        np.testing.assert_array_equal(skeleton.mass_offset, reference.mass_offset)


def test_omitted_origin_and_axis_take_the_spec_defaults(tmp_path):
    """No <origin> is the identity and no <axis> is 1 0 0 (URDF spec)."""
    explicit = _read(
        tmp_path,
        _joint('xyz="0 0 1" rpy="0 0 0"', 'xyz="0 0 0" rpy="0 0 0"').replace(
            '<axis xyz="0 0 1"/>', '<axis xyz="1 0 0"/>'
        ),
        "explicit.urdf",
    )
    omitted = _read(
        tmp_path,
        _robot(JOINT.replace('<origin xyz="0 0 1" rpy="0 0 0"/>', "").replace('<axis xyz="0 0 1"/>', "")),
        "omitted.urdf",
    )
    partial = _read(tmp_path, _joint('xyz="0 0 1" rpy="0 0 0"', "").replace('xyz="0 0 1"', ""), "partial.urdf")
    for skeleton in (omitted, partial):
        np.testing.assert_array_equal(skeleton.dof_axis, [[1.0, 0.0, 0.0]])
        for field in ("offsets", "joint_rotation", "dof_axis"):
            np.testing.assert_array_equal(getattr(skeleton, field), getattr(explicit, field))


def test_plain_decimals_in_every_spelling_are_read(tmp_path):
    skeleton = _read(
        tmp_path,
        _joint('xyz="0 0 1" rpy="0 0 0"', 'xyz="+.5 -0. 1E-1" rpy="\t0  0\n0 "').replace(
            'lower="-1" upper="1"', 'lower="-1.5e+0" upper="2."'
        ),
    )
    np.testing.assert_array_equal(skeleton.offsets[1], [0.5, 0.0, 0.1])
    assert (skeleton.lower[0], skeleton.upper[0]) == (-1.5, 2.0)


def test_origin_rpy_is_yaw_pitch_roll_about_fixed_axes(tmp_path):
    """URDF: R = Rz(yaw) Ry(pitch) Rx(roll), i.e. extrinsic x-y-z rotations by roll, pitch, yaw."""
    rpy = (0.3, -1.1, 2.5)
    skeleton = _read(tmp_path, _joint('rpy="0 0 0"', 'rpy="{} {} {}"'.format(*rpy)))
    np.testing.assert_allclose(skeleton.joint_rotation[1], Rotation.from_euler("xyz", rpy).as_matrix(), atol=1e-15)


def test_massless_links_have_no_segment(tmp_path):
    skeleton = _read(tmp_path, _robot(links=LINKS.replace('value="2"', 'value="0"')))
    assert skeleton.total_mass == 0 and len(skeleton.mass_value) == 0


def test_nothing_is_printed_for_good_or_bad_files(tmp_path, capfd):
    _read(tmp_path, _robot(), "good.urdf")
    for case in ("underscore", "billion laughs", "mimic of fixed"):
        with pytest.raises(FileFormatError):
            _read(tmp_path, BAD[case][0])
    assert capfd.readouterr() == ("", "")


def test_joint_types_outside_the_selected_chain_do_not_matter(tmp_path):
    """Joint types and limits are checked only where used: a floating joint off the chain is fine."""
    extra = '<joint name="f" type="floating"><parent link="a"/><child link="c"/></joint>'
    path = tmp_path / "robot.urdf"
    path.write_text(_robot(JOINT + extra, LINKS + '<link name="c"/>'))
    with pytest.raises(FileFormatError, match="joint 'f': a floating joint frees the robot's base"):
        read_urdf(path)
    assert read_urdf(path, tip="b").dof_names == ("j",)


def test_urdf_is_read_without_yourdfpy_or_trimesh(tmp_path):
    """yourdfpy is a test-only oracle: deik itself must read URDF with neither it nor trimesh importable."""
    import subprocess
    import sys

    path = tmp_path / "robot.urdf"
    path.write_text(_robot())
    code = (
        "import sys; sys.modules['yourdfpy'] = sys.modules['trimesh'] = None\n"
        f"import deik; print(deik.read_urdf({str(path)!r}).dof_names)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout == "('j',)\n", done.stderr
