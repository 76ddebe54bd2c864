"""references: closed-form exact solutions for the cross-check harness (pure functions of
physical parameters and initial conditions; no dependency on the harness engines).

Modules: ``torque_free`` (Euler's equations without moment, Jacobi elliptic solution),
``heavy_top`` (Lagrange top nutation u = cos θ, tip force), ``double_pendulum`` (linearised
modes and exact modal response), ``plate_pendulum`` (compound pendulum about a corner, support
force), ``cart_pendulum`` (cart on a rail with a pendulum), ``spring_pendulum`` (particle on a
spring), ``rotating_plate`` (bearing couple of a plate on a skew axis), ``errata`` (the printed results found wrong; generates ``ERRATA.md``).  See
``references/README.md`` for textbook locations.
"""

from harness.references import cart_pendulum
from harness.references import double_pendulum
from harness.references import heavy_top
from harness.references import plate_pendulum
from harness.references import rotating_plate
from harness.references import spring_pendulum
from harness.references import torque_free

__all__ = ["torque_free", "heavy_top", "double_pendulum", "plate_pendulum", "cart_pendulum", "spring_pendulum",
           "rotating_plate"]
