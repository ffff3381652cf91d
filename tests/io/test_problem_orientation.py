"""Problem files give an orientation in one named form per goal; each reads as the rotation
scipy makes of the same numbers (degrees where the key says so)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deik.solver.problem_file import load_problem

ROTATION = Rotation.from_euler("xyz", [20.0, -35.0, 110.0], degrees=True)


def _table(value) -> str:
    return str(np.asarray(value).tolist())


def _forms():
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = ROTATION.as_matrix(), [1.0, 2.0, 3.0]
    xyzw = ROTATION.as_quat()
    return {
        "target": _table(ROTATION.as_matrix()),
        "pose": _table(T),
        "quaternion_wxyz": _table(xyzw[[3, 0, 1, 2]]),
        "quaternion_xyzw": _table(xyzw),
        "rpy_degrees": "[20.0, -35.0, 110.0]",
    }


@pytest.mark.parametrize("key", sorted(_forms()))
def test_each_orientation_key_reads_as_scipys_rotation(tmp_path, key):
    path = tmp_path / "problem.toml"
    path.write_text(f'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n{key} = {_forms()[key]}\n')
    goal = load_problem(path).problem.goals[0]
    np.testing.assert_allclose(goal.rotation()[0], ROTATION.as_matrix(), atol=1e-9)


def test_euler_with_degrees_still_reads(tmp_path):
    path = tmp_path / "problem.toml"
    angles = ROTATION.as_euler("XYZ", degrees=True).tolist()
    path.write_text(
        f'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\neuler = "XYZ"\ndegrees = {angles}\n'
    )
    np.testing.assert_allclose(load_problem(path).problem.goals[0].rotation()[0], ROTATION.as_matrix(), atol=1e-9)
