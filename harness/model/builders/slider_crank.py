"""slider_crank: a crank, a connecting rod and a slider (piston) under gravity and a constant
force on the slider, closed by a cut hinge between rod and slider (Ex. 5.1.1's crankshaft).

Geometry (SI units). The mechanism moves in the world x-z plane (gravity -g z); hinge axes are
world -y, so a positive angle turns +x toward +z. Crank (length a, mass m_crank) hinged to the
world at the origin, absolute angle theta; connecting rod (length b, m_rod) hinged to the crank's
tip B, absolute angle phi (joint coordinate phi - theta); both uniform solid cylinders of radius r
along body +x, body frames at the proximal joint. The slider (a cube of side w, mass m_slider,
centre of mass at its pin C) slides along world x on the line z = e: its coordinate is the pin's
x. The cut hinge ``cut`` joins the rod's tip and the slider's pin.

Closure (the slider on the +x side of the crank): x = a cos theta + sqrt(b^2 - (e - a sin theta)^2),
sin phi = (e - a sin theta) / b. A constant force F (N) along world +x acts on the slider at its
pin (F < 0 pushes it toward the crank); F = 0 leaves the scene unforced.
"""

from __future__ import annotations

import numpy as np

from harness.model.builders.four_bar import AXIS, bar_inertia
from harness.model.errors import InputError
from harness.model.multibody import Body, LoopJoint, Multibody, PointForce


def assemble(a: float, b: float, e: float, theta: float, dtheta: float) -> tuple[float, float, float, float]:
    """(phi, x, phi', x') at crank angle theta (rad) and rate dtheta (rad/s) (module docstring);
    InputError when the rod cannot reach the slider's line."""
    s = (e - a * np.sin(theta)) / b
    if not abs(s) < 1.0:
        raise InputError(f"slider-crank cannot close at theta = {theta:g} rad: the rod (b = {b:g} m) does not reach "
                         f"the slider line z = {e:g} m from the crank tip")
    phi = float(np.arcsin(s))
    x = a * np.cos(theta) + b * np.cos(phi)
    dphi = -a * np.cos(theta) * dtheta / (b * np.cos(phi))
    dx = -a * np.sin(theta) * dtheta - b * np.sin(phi) * dphi
    return phi, float(x), float(dphi), float(dx)


def build(params: dict) -> Multibody:
    a, b, e, r, w = (float(params[k]) for k in ("a", "b", "e", "r", "w"))
    if not a + abs(e) < b:
        raise InputError(f"slider-crank: the crank must turn fully, a + |e| < b (a = {a:g}, e = {e:g}, b = {b:g} m)")
    theta0, dtheta0 = float(params["theta0"]), float(params["dtheta0"])
    phi0, x0, dphi0, dx0 = assemble(a, b, e, theta0, dtheta0)
    m_c, m_r, m_s = float(params["m_crank"]), float(params["m_rod"]), float(params["m_slider"])
    bodies = (
        Body("crank", None, "hinge", np.zeros(3), AXIS, m_c, np.array([0.5 * a, 0.0, 0.0]), bar_inertia(m_c, a, r)),
        Body("rod", "crank", "hinge", np.array([a, 0.0, 0.0]), AXIS, m_r, np.array([0.5 * b, 0.0, 0.0]),
             bar_inertia(m_r, b, r)),
        Body("slider", None, "slide", np.array([0.0, 0.0, e]), np.array([1.0, 0.0, 0.0]), m_s, np.zeros(3),
             np.eye(3) * m_s * w * w / 6.0),
    )
    cut = LoopJoint("cut", "hinge", "rod", "slider", np.array([b, 0.0, 0.0]), np.zeros(3), AXIS, AXIS,
                    hinge_span=w)
    q0 = {"crank": np.array([theta0]), "rod": np.array([phi0 - theta0]), "slider": np.array([x0])}
    v0 = {"crank": np.array([dtheta0]), "rod": np.array([dphi0 - dtheta0]), "slider": np.array([dx0])}
    F = float(params["F"])
    forces: tuple[PointForce, ...] = ()
    if F != 0.0:
        forces = (PointForce.harmonic("slider", np.zeros(3), np.array([F, 0.0, 0.0]), name="piston"),)  # constant
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=bodies, gravity_W=gravity, q0=q0, v0=v0, forces=forces, loops=(cut,))
