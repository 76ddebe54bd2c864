"""Rolling without slip on the plane z = 0 as a constraint of the in-house Newton-Euler model.

A rolling contact (``harness.model.multibody.RollingContact``) adds three rows to the KKT system,
after the joint rows (ball/hinge, then slide): the velocity of the body's material point at the
contact point C is zero. With ``r = r_AC_W`` the offset from the centre of mass A to C (world;
``harness.model.rolling_contact``: C is the lowest point of the lower rim edge, or of the one
rolling circle of a contact with ``circle_z``, and moves around the
rim) and ``u = [v_WA_W, w_WB_B]`` the generalised velocity of the model::

    v_C = v_A + w x r = [ I3 | -[r]x R ] u = J u = 0                          (3 rows, m/s)
    dv_C/dt = J du/dt + gamma,  gamma = w x r'      (r' = d r/dt, ``contact_offset_rate``)

The x and y rows are nonholonomic: they have no position-level error, so their ``C`` entries
are 0 and Baumgarte stabilisation (variable-step methods) only damps their velocity error. The
z row is the derivative of the holonomic height condition ``z_C = z_A + r_z = 0``, its ``C``
entry (m); the post-step projection of the fixed-step methods moves the positions back to
z_C = 0 (Gauss-Newton: the height row's Jacobian is the material point's, by the envelope
argument of ``harness.model.rolling_contact``) and projects the velocities onto J u = 0 (all three
rows). The projection is a mass-weighted orthogonal projection, i.e. a perfectly plastic impulse
at C: an edge switch (the upright cylinder tipping over to its other rim edge, where the
contact point jumps by 2h along the axis) is such an impact and dissipates energy.

The multipliers of the three rows are the contact force (N, world) the plane exerts on the body
at C: ``J^T lambda`` is the force lambda at C and the moment ``r x lambda`` about A. The
contact is bilateral (no check that the normal force stays positive; ``contact_forces`` reports
it).

Derivation: the constraint was not obtained by substituting the rolling condition into a
Lagrangian (which gives wrong equations for nonholonomic constraints, Boström Ex. 5.2.3); the
contact force is an unknown of Newton-Euler, and the no-slip condition is imposed on the
accelerations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.model import rolling_contact, rotations
from harness.engines.inhouse import algebra
from harness.measure.trajectory import Failure


@dataclass(frozen=True)
class RollingRows:
    """One rolling contact of the in-house model.

    Attributes:
        name: the contact's name (``RollingContact.name``).
        body: index of the rolling body.
        radius, half_thickness: rim radius and half-thickness (m).
        circle_z: None (two rim edges), or the body z (m) of the one rolling circle's centre
            (``RollingContact.circle_z``).
    """

    name: str
    body: int
    radius: float
    half_thickness: float
    circle_z: float | None = None


class FlatDiskError(ArithmeticError):
    """The rolling body lies flat: the contact point is undefined."""

    reason = Failure.SINGULAR


def build_contacts(model, index: dict[str, int]) -> tuple[RollingRows, ...]:
    """The rolling contacts of a ``Multibody`` (none when it has no ``contacts``)."""
    return tuple(RollingRows(c.name, index[c.body], float(c.radius), float(c.half_thickness),
                             None if c.circle_z is None else float(c.circle_z))
                 for c in getattr(model, "contacts", ()))


def rolling_rows(contacts: tuple[RollingRows, ...], nb: int, P_ext: np.ndarray, R_ext: np.ndarray,
                 w_ext: np.ndarray | None):
    """``(C, J, gamma)`` of the rolling rows: shapes (3k,), (3k, 6 nb), (3k,) for k contacts
    (gamma None when ``w_ext`` is None). Rows per contact: x, y (no slip), z (height)."""
    k = len(contacts)
    C = np.zeros(3 * k)
    J = np.zeros((3 * k, 6 * nb))
    gamma = None if w_ext is None else np.zeros(3 * k)
    for j, c in enumerate(contacts):
        i = c.body
        R = R_ext[i]
        r, r_dot, s = rolling_contact.offset_and_rate(R, None if w_ext is None else w_ext[i], c.radius, c.half_thickness,
                                                  c.circle_z)
        if s < rolling_contact.FLAT:
            raise FlatDiskError(f"rolling contact {c.name!r}: the disk lies flat, the contact point is undefined")
        rows = slice(3 * j, 3 * j + 3)
        C[3 * j + 2] = P_ext[i, 2] + r[2]
        J[rows, 3 * i : 3 * i + 3] = np.eye(3)
        J[rows, 3 * nb + 3 * i : 3 * nb + 3 * i + 3] = -algebra.skew(r) @ R
        if gamma is not None:
            gamma[rows] = rotations.cross(w_ext[i], r_dot)
    return C, J, gamma


def contact_forces(contacts: tuple[RollingRows, ...], lam_contacts: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per contact ``(force_W, moment_W)``: the force (N, world) the plane exerts on the body at
    the contact point (the rows' multipliers) and the moment about the contact point (zero: a
    point contact)."""
    return {c.name: (np.array(lam_contacts[3 * j : 3 * j + 3], dtype=float), np.zeros(3))
            for j, c in enumerate(contacts)}
