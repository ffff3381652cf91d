"""Named kernel data: the device namespaces resolve calls on their own target, the engine's
state matches the NamedTuples, and the packed arrays carry their names."""

import dataclasses
import inspect

import numpy as np
from numba.core.dispatcher import Dispatcher

import deik
from deik.backends import targets
from deik.backends.pack import pack_skeleton
from deik.device import driver as device_driver
from deik.device import layout
from deik.device import lm as device_lm
from deik.device import terms as device_terms
from helpers import robot_arm


def test_device_imports_resolve_to_the_compiled_namespace():
    for module in (device_terms, device_lm, device_driver):
        for name, value in vars(module).items():
            if inspect.isfunction(value):
                compiled = getattr(targets.cpu, name)
                assert isinstance(compiled, Dispatcher), name
                assert compiled.py_func.__globals__ is vars(targets.cpu), name


def test_evolution_state_exposes_buffers_and_status_as_named_tuples():
    chain = deik.chain(3)
    engine = deik.Engine(deik.Problem(chain, [deik.Position("tip", [1.0, 1.0, 0.0])]), deik.Settings(population=8))
    state = engine.init()
    assert isinstance(state.buffers, layout.Buffers) and isinstance(state.status, layout.Status)
    assert state.buffers.pop is state.pop and state.status.leaders is state.leaders
    assert isinstance(engine.kernel_settings, layout.KernelSettings) and engine.polish_schedule.count == 8


def test_packed_skeleton_columns_are_named():
    chain = deik.chain(3)
    skel = pack_skeleton(chain, np.float64)
    assert isinstance(skel, layout.PackedSkeleton)
    np.testing.assert_array_equal(skel.joint_int[:, layout.PARENT], chain.parents)
    np.testing.assert_array_equal(skel.limits[:, layout.LOWER], chain.lower)


def test_rotations_spanning_a_whole_turn_are_marked_to_wrap_and_no_other_dof():
    chain = deik.chain(3)  # every joint +-pi: a whole turn
    narrow = deik.with_limits(chain, {"link1.Zrotation": (-3.0, 3.0)})
    for dtype in (np.float32, np.float64):
        turn = dtype(2 * np.pi)
        np.testing.assert_array_equal(pack_skeleton(chain, dtype).limits[:, layout.TURN], [turn] * 3)
        np.testing.assert_array_equal(pack_skeleton(narrow, dtype).limits[:, layout.TURN], [turn, 0, turn])
    # a slide 10 long is no turn; a wrist from -pi to 2 pi is one and a half
    arm = robot_arm()  # built with these limits (a limits table only narrows a hinge's)
    lower, upper = arm.lower.copy(), arm.upper.copy()
    for name, (low, high) in {"slide.Zposition": (-5.0, 5.0), "wrist.roll": (-np.pi, 2 * np.pi)}.items():
        lower[arm.dof_names.index(name)], upper[arm.dof_names.index(name)] = low, high
    arm = dataclasses.replace(arm, lower=lower, upper=upper)
    turns = pack_skeleton(arm, np.float64).limits[:, layout.TURN]
    np.testing.assert_array_equal(turns, [0, 0, 0, 0, 2 * np.pi, 0])
