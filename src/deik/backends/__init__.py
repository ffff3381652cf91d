"""The back-ends that compile and launch the device maths: the CPU (Numba prange kernels and
their host side) and the GPU (numba-cuda), packing and the per-target compile."""
