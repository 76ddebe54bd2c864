"""MuJoCo's integrators: the ``Integrator`` records the harness offers and MuJoCo's enum for each."""

from __future__ import annotations

import mujoco

from harness.engines.base import Integrator, integrator_table

INTEGRATOR_METHODS = integrator_table(
    Integrator("Euler", "fixed", 1, 1, "semi-implicit Euler (MuJoCo's default)"),
    Integrator("implicit", "fixed", 1, 1, "implicit in the velocity (damping and Coriolis terms), Euler in position"),
    Integrator("implicitfast", "fixed", 1, 1, "as implicit, without the Coriolis derivatives"),
    Integrator("RK4", "fixed", 4, 4, "classic RK4 on MuJoCo's configuration manifold"),
)
INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
}
