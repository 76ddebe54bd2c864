"""Fixed-step integrators on a Pinocchio configuration Lie group.

The state is ``(q, v)`` with ``q`` on the configuration manifold and ``v`` in its tangent space;
``accel(t, q, v)`` returns the acceleration ``a = dv/dt``.

* ``rkmk4``: classical RK4 in Runge-Kutta-Munthe-Kaas form. Stage configurations are
  ``q_i = integrate(q0, Theta_i)`` with ``Theta_i = h * sum_j a_ij k_j`` in the tangent space at
  ``q0``; each stage velocity is mapped back to that tangent space with the inverse of
  ``dIntegrate`` (the right-trivialised dexp), ``k_i = dIntegrate(q0, Theta_i)^-1 v_i``.
  Fourth order in configuration and velocity. A naive version that combines the stage
  velocities without this map is only second order in orientation.
* ``euler``: semi-implicit (symplectic) Euler, ``v+ = v + h a(q, v)``, ``q+ = integrate(q, h v+)``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import pinocchio as pin

from harness.engines.base import Integrator, integrator_table

Accel = Callable[[float, np.ndarray, np.ndarray], np.ndarray]

RK4_A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
RK4_B = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
RK4_C = (0.0, 0.5, 0.5, 1.0)


def rkmk4_step(model: pin.Model, accel: Accel, t: float, q: np.ndarray, v: np.ndarray, h: float):
    """One RKMK4 step of size ``h`` (s) from ``(q, v)`` at time ``t``; returns ``(q, v)``."""
    kq, kv = [], []
    for a_row, c in zip(RK4_A, RK4_C):
        theta = h * sum((a * k for a, k in zip(a_row, kq)), np.zeros(model.nv))
        dv = h * sum((a * k for a, k in zip(a_row, kv)), np.zeros(model.nv))
        q_i = pin.integrate(model, q, theta)
        v_i = v + dv
        if a_row and np.any(theta):
            J = pin.dIntegrate(model, q, theta, pin.ArgumentPosition.ARG1)
            kq.append(np.linalg.solve(J, v_i))
        else:
            kq.append(v_i)
        kv.append(accel(t + c * h, q_i, v_i))
    theta = h * sum(b * k for b, k in zip(RK4_B, kq))
    return pin.integrate(model, q, theta), v + h * sum(b * k for b, k in zip(RK4_B, kv))


def euler_step(model: pin.Model, accel: Accel, t: float, q: np.ndarray, v: np.ndarray, h: float):
    """One semi-implicit Euler step; returns ``(q, v)``."""
    v_next = v + h * accel(t, q, v)
    return pin.integrate(model, q, h * v_next), v_next


STEPPERS = {"rkmk4": rkmk4_step, "euler": euler_step}
METHODS = integrator_table(
    Integrator("rkmk4", "fixed", 4, 4, "Runge-Kutta-Munthe-Kaas RK4 on the configuration Lie group (pin.integrate, dIntegrate)"),
    Integrator("euler", "fixed", 1, 1, "semi-implicit Euler on the Lie group"),
)
