"""The compiled form of the in-house physics (Numba): scalar kernels (``kernels``) and their
drivers (``solver``). The engine runs them as ``rk4_compiled`` and ``dop853_compiled``."""
