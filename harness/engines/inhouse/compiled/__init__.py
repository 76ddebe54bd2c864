"""The in-house Newton-Euler equations compiled with Numba: scalar kernels, SIMD lanes, the solver."""
