"""Compile deik's CUDA kernels to PTX for sm_90 without a GPU; prints one line per kernel.

numba-cuda asks the driver for the compute capability when it compiles device functions;
with no driver here, that query is answered with (9, 0) so the real CUDA typing and lowering
path (not the simulator) runs. Needs NVVM (pip install "numba-cuda[cu13]").
"""

from types import SimpleNamespace

import numba.cuda.dispatcher as dispatcher

dispatcher.get_current_device = lambda: SimpleNamespace(compute_capability=(9, 0))

import numpy as np  # noqa: E402
from numba import cuda, typeof  # noqa: E402

import deik  # noqa: E402
from deik.backends import cuda as kernels  # noqa: E402

human = deik.humanoid()
rest = deik.forward_kinematics(human, human.reference)
problem = deik.Problem(human, [deik.Position("left_hand", rest.position("left_hand")), deik.Comfort(level=1)])
engine = deik.Engine(problem, deik.Settings(population=64))
state = engine.init()
B, D = 1, human.n_dofs
buffers, status = state.buffers, state.status
initialise, start, run = kernels.kernels_for(engine.skel, buffers)


def signature(*args):
    return tuple(typeof(a) for a in args)


run_args = (
    buffers,
    buffers,
    engine.skel,
    engine.terms,
    engine.kernel_settings,
    engine.memetic,
    status,
    engine.control,
    np.zeros((10, B, 2)),
    np.int64(0),
    np.int64(5),
    np.zeros(B, np.int64),
    np.zeros((B, int(engine.memetic.count), 2 * D * D), np.float32),
)
init_args = (
    buffers,
    status,
    engine.skel,
    engine.terms,
    engine.kernel_settings,
    np.zeros((B, 1, D), np.float32),
    np.int64(0),
)
start_args = (
    buffers,
    status,
    engine.skel,
    engine.terms,
    engine.kernel_settings,
    engine.memetic,
    engine.control,
    np.zeros((B, 1, D), np.float32),
    np.int64(0),
    np.zeros((B, 1, 2 * D * D), np.float32),
)
kernels_and_args = (("run", run, run_args), ("initialise", initialise, init_args), ("start", start, start_args))
for name, kernel, args in kernels_and_args:
    ptx, _ = cuda.compile_ptx(kernel.py_func, signature(*args), cc=(9, 0))
    print(name, "entry" if ".entry" in ptx else "missing", len(ptx))
