"""Run at start-up by every Python process the tests start in Numba's CUDA simulator
(helpers.simulator_env puts this folder on PYTHONPATH; processes those start inherit it).

The simulator runs each CUDA thread of a block as a Python thread and polls them from the main
thread, so every hand-over (a syncthreads, a thread ending) waits up to Python's GIL switch
interval; 0.5 ms instead of the default 5 ms runs the tests' simulated kernels 1.5 to 3 times
faster (shorter intervals slow the 128-thread blocks down again). Nothing a kernel computes
depends on it: the simulator's threads still meet at every syncthreads.
"""

import sys

sys.setswitchinterval(5e-4)
