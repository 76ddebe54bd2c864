"""references: one module per system -- its closed-form exact solutions and the exact checks
that judge the engines' runs with them (no dependency on the engines themselves).

The closed forms are pure functions of physical parameters and initial conditions. A module
whose scene declares ``[checks.exact]`` (``models/<scene>/scene.toml``) also states
``EXACT_NEEDS_RUNS`` and defines ``exact_error(scene, traj, settings, run)``, and where it
applies ``exact_error_series(scene, traj)`` and ``exact_reaction(scene, traj)``; these read the
run's trajectory (``harness.measure``) and the scene (``harness.model``), and make extra runs
only through the ``run`` callable the caller passes. ``harness.measure.exact`` finds them by
the scene's name; see ``references/README.md`` for the contract and the textbook locations.

Modules: ``torque_free`` (Euler's equations without moment, Jacobi elliptic solution),
``torque_free_symmetric`` (the symmetric free body's check: precession and cones, with
torque_free's closed forms), ``heavy_top`` (Lagrange top nutation u = cos θ, tip force),
``double_pendulum`` (linearised modes and exact modal response), ``plate_pendulum`` (compound
pendulum about a corner, support force), ``cart_pendulum`` (cart on a rail with a pendulum),
``spring_pendulum`` (particle on a spring), ``pendulum`` (IFToMM A01, the simple pendulum),
``rotating_plate`` (bearing couple of a plate on a skew axis), ``rolling_disk`` (steady circular
motion and stability of a rolling disk), ``bicycle`` (the Whipple bicycle benchmark of Meijaard et
al. 2007: linearised roll and steer equations, eigenvalues, weave and capsize speeds; no scene
yet), ``errata`` (the printed results found wrong; generates ``ERRATA.md``).
"""

from harness.references import cart_pendulum
from harness.references import double_pendulum
from harness.references import heavy_top
from harness.references import plate_pendulum
from harness.references import rolling_disk
from harness.references import rotating_plate
from harness.references import spring_pendulum
from harness.references import torque_free
from harness.references import torque_free_symmetric

__all__ = ["torque_free", "torque_free_symmetric", "heavy_top", "double_pendulum", "plate_pendulum", "cart_pendulum",
           "spring_pendulum", "rotating_plate", "rolling_disk"]
