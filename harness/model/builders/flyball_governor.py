"""flyball_governor: the stiff flyball governor of the IFToMM benchmark library (problem A05), a
tree of four bodies with two stiff spring-dampers in place of the coupler rods.

Geometry (SI units; world z up, gravity -g z). The shaft (a bar of length ``L_shaft`` and square
section ``w``) turns freely about world z on a hinge at its foot, the origin; its body frame is
the world's at zero angle, its centre of mass at (0, 0, L_shaft/2). The slider (a cube of side
``a_slider``) slides along the shaft's z axis; its body frame is at its centre, its coordinate
``s`` the height of that centre above the shaft's foot (the benchmark's output). Two rods (bars
of length ``L_rod``, section ``w``, with a point mass ``m_ball`` at the far end) hang from the
shaft's top on hinges A = (+x_AB/2, 0, L_shaft) and B = (-x_AB/2, 0, L_shaft) in the shaft's
frame: ``rod1`` lies along its body +x with hinge axis +y, ``rod2`` along its body -x with hinge
axis -y, so that for both the coordinate ``alpha`` is the angle of the rod below the horizontal
(the benchmark's alpha): rod1's direction is (cos alpha, 0, -sin alpha) in the shaft's frame,
rod2's (-cos alpha, 0, -sin alpha). Each rod body is the bar and its point mass together (one
rigid body: centre of mass x_c = (m_bar L_rod/2 + m_ball L_rod)/(m_bar + m_ball) along the rod,
the point mass adding only its parallel-axis term). Masses follow from the density ``rho``.

The springs ``spring1`` (slider point E = (+a_slider/2, 0, 0) to rod1's point (l_attach, 0, 0))
and ``spring2`` (F = (-a_slider/2, 0, 0) to rod2's (-l_attach, 0, 0)) have stiffness ``k``,
rest length ``l0`` and a damper ``c`` in parallel (``PointSpring``). At the benchmark's initial
state (s = 0.5 m, alpha = 30 deg, l_attach = 0.5 m, x_AB = a_slider = 0.1 m) each spring has
exactly its rest length: sqrt((0.5 cos 30)^2 + (1 - 0.5 sin 30 - 0.5)^2) = 0.5 m.

Initial state: shaft at angle 0 turning at ``omega0`` (rad/s) about z, the slider at ``s0``,
both rods at ``alpha0``, no motion relative to the shaft (``ds0``, ``dalpha0`` default 0).
"""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody, PointSpring

Z = np.array([0.0, 0.0, 1.0])
Y = np.array([0.0, 1.0, 0.0])


def bar_inertia(m: float, length: float, w: float) -> np.ndarray:
    """Inertia (kg m^2) about the centre of a uniform bar of length ``length`` along body x and
    square section of side ``w`` (m): diag(m 2w^2/12, m (L^2 + w^2)/12, m (L^2 + w^2)/12)."""
    axial, transverse = m * 2.0 * w * w / 12.0, m * (length * length + w * w) / 12.0
    return np.diag([axial, transverse, transverse])


def rod_properties(params) -> tuple[float, float, np.ndarray]:
    """``(mass, x_c, I_Cm)`` of a rod with its point mass (kg, m along the rod from the hinge,
    kg m^2 about the centre of mass with body x along the rod; module docstring)."""
    L, w, rho, m_ball = (float(params[k]) for k in ("L_rod", "w", "rho", "m_ball"))
    m_bar = rho * w * w * L
    m = m_bar + m_ball
    x_c = (m_bar * 0.5 * L + m_ball * L) / m
    shift = m_bar * (0.5 * L - x_c) ** 2 + m_ball * (L - x_c) ** 2
    return m, x_c, bar_inertia(m_bar, L, w) + np.diag([0.0, shift, shift])


def build(params: dict) -> Multibody:
    L_shaft, L_rod, w, a = (float(params[k]) for k in ("L_shaft", "L_rod", "w", "a_slider"))
    rho, x_ab, l_attach = float(params["rho"]), float(params["x_AB"]), float(params["l_attach"])
    if not 0.0 < l_attach <= L_rod:
        raise InputError(f"flyball governor: the spring's point on the rod, l_attach = {l_attach:g} m, must lie on the "
                         f"rod (0 < l_attach <= L_rod = {L_rod:g} m)")
    m_shaft = rho * w * w * L_shaft
    shaft_I = np.diag(np.roll(np.diag(bar_inertia(m_shaft, L_shaft, w)), -1))  # the bar along body z
    m_slider = rho * a**3
    m_rod, x_c, rod_I = rod_properties(params)
    top = np.array([0.5 * x_ab, 0.0, L_shaft])
    mirror = np.array([-1.0, 1.0, 1.0])
    bodies = (  # the shaft's children in their names' order, as every reader of the URDF lists them
        Body("shaft", None, "hinge", np.zeros(3), Z, m_shaft, np.array([0.0, 0.0, 0.5 * L_shaft]), shaft_I),
        Body("rod1", "shaft", "hinge", top, Y, m_rod, np.array([x_c, 0.0, 0.0]), rod_I),
        Body("rod2", "shaft", "hinge", mirror * top, -Y, m_rod, np.array([-x_c, 0.0, 0.0]), rod_I),
        Body("slider", "shaft", "slide", np.zeros(3), Z, m_slider, np.zeros(3), np.eye(3) * m_slider * a * a / 6.0),
    )
    k, c, l0 = float(params["k"]), float(params["c"]), float(params["l0"])
    springs = (
        PointSpring("spring1", "slider", np.array([0.5 * a, 0.0, 0.0]), "rod1", np.array([l_attach, 0.0, 0.0]),
                    k, l0, c),
        PointSpring("spring2", "slider", np.array([-0.5 * a, 0.0, 0.0]), "rod2", np.array([-l_attach, 0.0, 0.0]),
                    k, l0, c),
    )
    alpha0, dalpha0 = float(params["alpha0"]), float(params["dalpha0"])
    q0 = {"shaft": np.array([0.0]), "rod1": np.array([alpha0]), "rod2": np.array([alpha0]),
          "slider": np.array([float(params["s0"])])}
    v0 = {"shaft": np.array([float(params["omega0"])]), "rod1": np.array([dalpha0]), "rod2": np.array([dalpha0]),
          "slider": np.array([float(params["ds0"])])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=bodies, gravity_W=gravity, q0=q0, v0=v0, point_springs=springs)
