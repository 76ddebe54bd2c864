"""The Drake integrators the harness runs, by the ``--integrator`` name, and Drake's scheme name
(``pydrake.systems.analysis.ResetIntegratorFromFlags``).

* ``RK3``, ``RK5``: explicit Runge-Kutta with Drake's error control (``runge_kutta3``: order 3
  with an embedded order-2 estimate; ``runge_kutta5``: Dormand-Prince 5(4)) at a target
  accuracy (the run's ``rtol``; Drake's accuracy is a relative error measure of its own, not a
  SciPy rtol), the maximum step the run's ``dt`` (the scene's step unless a run sets another),
  never the save interval: with the save interval (0.005 s on heavy_top) as its maximum step,
  ``harness simulate heavy_top --engine drake --save-every 1`` (a 1 s maximum step) did not
  return from ``AdvanceTo`` (stopped after minutes).
* ``Radau3``: implicit two-stage Radau IIA (order 3) with error control, for stiff systems.
* ``RK3_fixed``: Drake's ``runge_kutta3`` in fixed-step mode at ``dt``: Drake's only explicit
  Runge-Kutta of order above 2 that runs at a fixed step (Drake has no RK4).
* ``RK2``: explicit midpoint (``runge_kutta2``), fixed step only.

The error-controlled runs leave the first step to Drake: the run's ``dt`` is their maximum step,
not passed as ``request_initial_step_size_target``. Measured with Drake 1.51.1 on heavy_top (target accuracy
1e-8, maximum step 0.2 s): an initial step target of 0.05 s reaches t = 2 s in 0.03 s, one of
0.1 s or 0.19 s never returns from ``AdvanceTo`` (stopped after 20 s).
"""

from __future__ import annotations

from harness.engines.base import Integrator, integrator_table

METHODS = integrator_table(
    Integrator("RK3", "adaptive", 3, 3, "Drake runge_kutta3 (order 3, embedded order-2 error estimate), target accuracy"),
    Integrator("RK5", "adaptive", 5, 6, "Drake runge_kutta5 (Dormand-Prince 5(4)), target accuracy"),
    Integrator("Radau3", "adaptive", 3, None, "Drake radau3 (implicit Radau IIA, two stages), target accuracy"),
    Integrator("RK3_fixed", "fixed", 3, 3, "Drake runge_kutta3 in fixed-step mode"),
    Integrator("RK2", "fixed", 2, 2, "Drake runge_kutta2 (explicit midpoint), fixed step"),
)

#: ``--integrator`` name -> Drake's scheme name.
SCHEMES = {"RK3": "runge_kutta3", "RK5": "runge_kutta5", "Radau3": "radau3", "RK3_fixed": "runge_kutta3",
           "RK2": "runge_kutta2"}
