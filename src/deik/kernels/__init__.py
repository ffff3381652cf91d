"""Compiled maths: named kernel data, device functions written once, CPU (Numba) and CUDA back-ends."""
