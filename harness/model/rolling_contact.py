"""Geometry of a cylinder's rim edge rolling on the horizontal plane z = 0.

The rolling body is a cylinder of radius ``R`` and half-thickness ``h`` whose symmetry axis is
body z through its centre of mass A. Its rim edges are the two circles at body z = +-h. Resting
on the plane z = 0 with its axis tilted, it touches the plane at the lowest point of the lower
edge circle: with ``n = R_WB e_z`` the axis in world and ``u`` the unit upward direction within
the disk plane, ``u = (e_z - n_z n) / sqrt(1 - n_z^2)``, the contact point C is::

    r_AC_W = -R u - h sgn(n_z) n                                         (m, world)

(sgn(n_z) picks the edge nearer the ground; at n_z = 0 exactly, the upright cylinder touches
along a segment and sgn(0) = 0 gives its midpoint). The height of C is then
``z_A - R sqrt(1 - n_z^2) - h |n_z|``. C moves around the rim as the body turns; its rate in
world, at angular velocity ``w_W`` (n' = w x n)::

    u' = (-n_z' n - n_z n' + u n_z n_z' / s) / s,   s = sqrt(1 - n_z^2)
    r_AC_W' = -R u' - h sgn(n_z) n'

Rolling without slip is ``v_A + w x r_AC = 0`` (the material point at C at rest); its time
derivative is ``a_A + alpha x r_AC + w x r_AC' = 0``: the constraint bias of every engine is
``gamma = w x r_AC'``. The height is a minimum over the edge circle, so (envelope) its
derivative with respect to a rotation of the body is that of the material point: the height
row of the Jacobian is the z row of the no-slip rows. The geometry is singular when the disk
lies flat (|n_z| = 1).

One circle instead of two edges (``circle_z``, ``RollingContact.circle_z``): when the body rolls
on a single circle of radius ``R`` centred on its axis at body z = ``c`` (m, from A along n) -- a
cylinder lying on its side rolls on its mid circle c = 0 as long as its axis stays horizontal (the
contact segment's midpoint); a cone's base rim -- the contact point is the lowest point of that
circle and the edge term becomes a constant axial offset::

    r_AC_W = -R u + c n,   r_AC_W' = -R u' + c n'

(the same formulas with ``h sgn(n_z)`` replaced by ``-c``; no edge switch exists, and the height,
envelope argument and bias are unchanged).

The rolling body may be any body of the tree: a root (free, or on a joint to the world) or a
body deep in it (a bicycle's front wheel: rear frame, front frame, wheel). Its three rows repeat
others only where the world holds it through joints alone (``dependent_rows``).

Everything broadcasts over leading axes: rotations ``[..., 3, 3]``, vectors ``[..., 3]``.
"""

from __future__ import annotations

import numpy as np

from harness.model.joints import JOINTS
from harness.model.rotations import cross

FLAT = 1e-9  # sqrt(1 - n_z^2) below this: the disk lies flat and the contact point is undefined


def axis_and_up(R_WB: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(n, u, s)``: the symmetry axis n = R e_z (world), the unit upward direction u in the
    disk plane, and s = sqrt(1 - n_z^2) (the sine of the tilt of the axis from the vertical)."""
    n = np.asarray(R_WB)[..., :, 2]
    nz = n[..., 2]
    s = np.sqrt(np.maximum(1.0 - nz * nz, 0.0))
    ez = np.array([0.0, 0.0, 1.0])
    u = (ez - nz[..., None] * n) / np.maximum(s, FLAT)[..., None]
    return n, u, s


def _axial(n_z, half_thickness: float, circle_z: float | None):
    """The coefficient k of the axial term ``k n`` of r_AC: ``-h sgn(n_z)`` (the lower of the two
    rim edges) or, for one circle, ``circle_z``."""
    if circle_z is not None:
        return float(circle_z) * np.ones_like(n_z)
    return -half_thickness * np.sign(n_z)


def contact_offset(R_WB: np.ndarray, radius: float, half_thickness: float, circle_z: float | None = None) -> np.ndarray:
    """``r_AC_W`` (m, world): from the centre A to the contact point C (module docstring); with
    ``circle_z`` (m) the body rolls on the one circle centred at body z = circle_z."""
    n, u, _ = axis_and_up(R_WB)
    k = _axial(n[..., 2], half_thickness, circle_z)[..., None]
    return -radius * u + k * n


def contact_offset_rate(R_WB: np.ndarray, w_W: np.ndarray, radius: float, half_thickness: float,
                        circle_z: float | None = None) -> np.ndarray:
    """``d r_AC_W / dt`` (m/s, world) at world angular velocity ``w_W`` (rad/s): the motion of
    the contact point around the rim, plus the body's rotation of it (module docstring; with
    ``circle_z`` the one circle at body z = circle_z)."""
    n, u, s = axis_and_up(R_WB)
    s = np.maximum(s, FLAT)[..., None]
    nz = n[..., 2:3]
    ndot = cross(np.asarray(w_W, dtype=float), n)
    nzdot = ndot[..., 2:3]
    udot = (-nzdot * n - nz * ndot + u * nz * nzdot / s) / s
    k = _axial(nz, half_thickness, circle_z)
    return -radius * udot + k * ndot


def offset_and_rate(R_WB: np.ndarray, w_W: np.ndarray | None, radius: float, half_thickness: float,
                    circle_z: float | None = None):
    """One body (R_WB 3x3, w_W (3,) or None): ``(r_AC_W, r_AC_W' or None, s)`` with
    s = sqrt(1 - n_z^2), the same formulas as ``contact_offset`` / ``contact_offset_rate`` in
    scalar arithmetic (the engines' right-hand sides call it at every stage)."""
    n0, n1, nz = float(R_WB[0, 2]), float(R_WB[1, 2]), float(R_WB[2, 2])
    s = (max(1.0 - nz * nz, 0.0)) ** 0.5
    si = 1.0 / max(s, FLAT)
    u0, u1, u2 = -nz * n0 * si, -nz * n1 * si, (1.0 - nz * nz) * si
    if circle_z is None:
        hs = half_thickness * (1.0 if nz > 0.0 else (-1.0 if nz < 0.0 else 0.0))
    else:
        hs = -float(circle_z)
    r = np.array([-radius * u0 - hs * n0, -radius * u1 - hs * n1, -radius * u2 - hs * nz])
    if w_W is None:
        return r, None, s
    w0, w1, w2 = float(w_W[0]), float(w_W[1]), float(w_W[2])
    d0, d1, d2 = w1 * nz - w2 * n1, w2 * n0 - w0 * nz, w0 * n1 - w1 * n0  # n' = w x n
    k = nz * d2 * si
    ud0 = (-d2 * n0 - nz * d0 + u0 * k) * si
    ud1 = (-d2 * n1 - nz * d1 + u1 * k) * si
    ud2 = (-d2 * nz - nz * d2 + u2 * k) * si
    rdot = np.array([-radius * ud0 - hs * d0, -radius * ud1 - hs * d1, -radius * ud2 - hs * d2])
    return r, rdot, s


def contact_height(p_WA_W: np.ndarray, R_WB: np.ndarray, radius: float, half_thickness: float,
                   circle_z: float | None = None) -> np.ndarray:
    """Height z (m) of the contact point above the plane (negative: penetration)."""
    return p_WA_W[..., 2] + contact_offset(R_WB, radius, half_thickness, circle_z)[..., 2]


def slip_velocity(v_WA_W: np.ndarray, w_W: np.ndarray, R_WB: np.ndarray, radius: float,
                  half_thickness: float, circle_z: float | None = None) -> np.ndarray:
    """Velocity (m/s, world) of the body's material point at the contact point:
    ``v_A + w x r_AC``. Zero for rolling without slip; its z component is the rate of the
    contact height."""
    return v_WA_W + cross(w_W, contact_offset(R_WB, radius, half_thickness, circle_z))


def is_flat(R_WB: np.ndarray) -> np.ndarray:
    """Whether the disk lies flat (the contact point undefined)."""
    return axis_and_up(R_WB)[2] < FLAT


def anchored(model, body: str) -> bool:
    """Whether the world holds ``body`` of ``model`` (a ``Multibody``) through joints alone: no free
    joint on its chain to the world (a cone on a ball joint at its apex; not a bicycle's wheel,
    whose rear frame is free)."""
    while body is not None:
        b = model.body(body)
        if not JOINTS[b.joint].constrained:
            return False
        body = b.parent
    return True


def dependent_rows(model) -> bool:
    """Whether the rolling rows of ``model`` may repeat other rows, so that the engines must solve
    for dependent rows: a contact on an ``anchored`` body (two points of one rigid body at rest,
    the joint's and the contact's, have equal velocities along the line joining them: one no-slip
    row repeats the joints'), or two contacts on one body (the same argument between the two
    contact points). A contact on a body whose chain to the world has a free joint (a rolling
    disk, a bicycle's wheels) adds independent rows."""
    bodies = [c.body for c in getattr(model, "contacts", ())]
    return len(set(bodies)) < len(bodies) or any(anchored(model, b) for b in bodies)
