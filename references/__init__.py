"""references: closed-form exact solutions for the cross-check harness (pure functions of
physical parameters and initial conditions; no dependency on the harness engines).

Modules: ``torque_free`` (Euler's equations without moment, Jacobi elliptic solution),
``heavy_top`` (Lagrange top nutation u = cos θ), ``double_pendulum`` (linearised modes and
exact modal response).  See ``references/README.md`` for textbook locations and errata.
"""

from references import double_pendulum, heavy_top, torque_free

__all__ = ["torque_free", "heavy_top", "double_pendulum"]
