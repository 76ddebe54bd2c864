"""rolling_cylinder_bar: a uniform cylinder rolling without slip on the horizontal plane z = 0, its
axis horizontal along world -y, with a bar pinned at one end to the cylinder's axis and swinging
freely in the x-z plane, gravity -g z (Boström Problem 5.13)."""

from __future__ import annotations

import numpy as np

from harness.model import rotations
from harness.model.errors import InputError
from harness.model.multibody import Body, Multibody, RollingContact

# The cylinder's body frame at zero roll: a rotation of +pi/2 about world x takes body z (its
# symmetry axis) to world -y and body y to world +z. The bar's hinge axis is the cylinder's body
# z (world -y): a positive angle swings the bar's free end from straight down toward +x.
R_CYLINDER0 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
HINGE_AXIS = np.array([0.0, 0.0, 1.0])


def cylinder_inertia(M: float, R: float, h: float) -> np.ndarray:
    """Solid cylinder of mass M (kg), radius R and half-length h (m) about its centre, body z
    along the axis (kg m^2): transverse M (R^2/4 + h^2/3), axial M R^2 / 2."""
    transverse = M * (R * R / 4.0 + h * h / 3.0)
    return np.diag([transverse, transverse, 0.5 * M * R * R])


def bar_inertia(m: float, L: float, a: float) -> np.ndarray:
    """Solid round bar of mass m (kg), length L and radius a (m) about its centre, body y along
    the bar (kg m^2): transverse m (L^2/12 + a^2/4), axial m a^2 / 2 (the textbook's thin bar:
    a -> 0)."""
    transverse = m * (L * L / 12.0 + a * a / 4.0)
    return np.diag([transverse, 0.5 * m * a * a, transverse])


def min_normal_force(M: float, m: float, R: float, L: float, a: float, g: float, theta0: float, dx0: float,
                     dtheta0: float, n: int = 4001) -> tuple[float, float]:
    """``(N_min, theta)``: the smallest normal force (N) of the plane on the cylinder over the
    motion, and the bar angle (rad) where it occurs. The planar motion conserves p_x and the
    energy, so the bar's rate and acceleration, and with them the normal force, are functions of
    the bar angle alone (``references/rolling_cylinder_bar.py``, steps 3, 4 and 7)::

        theta'^2 = 2 (E_rel + m g l cos) / J,   J theta'' = -m g l sin - m^2 l^2 sin cos theta'^2 / S
        N = (M + m) g + m l (sin theta'' + cos theta'^2)

    evaluated on ``n`` angles over the reachable range (the libration's, or a full turn)."""
    l, S = 0.5 * L, 1.5 * M + m
    I_O = m * (L * L / 12.0 + a * a / 4.0) + m * l * l
    c0 = np.cos(theta0)
    P = S * dx0 + m * l * c0 * dtheta0
    E = 0.5 * S * dx0 * dx0 + m * l * c0 * dx0 * dtheta0 + 0.5 * I_O * dtheta0 * dtheta0 - m * g * l * c0
    E_rel = E - P * P / (2.0 * S)
    mgl = m * g * l
    if mgl > 0.0 and E_rel < mgl:  # libration: |theta| <= theta_m (mod 2 pi), E_rel + m g l cos(theta_m) = 0
        top = float(np.arccos(np.clip(-E_rel / mgl, -1.0, 1.0)))
    else:
        top = np.pi
    th = np.linspace(-top, top, n)
    c, s = np.cos(th), np.sin(th)
    J = I_O - (m * l * c) ** 2 / S
    rate2 = np.maximum(2.0 * (E_rel + mgl * c) / J, 0.0)
    acc = (-mgl * s - (m * l) ** 2 * s * c * rate2 / S) / J
    N = (M + m) * g + m * l * (s * acc + c * rate2)
    k = int(np.argmin(N))
    return float(N[k]), float(th[k])


def build(params: dict) -> Multibody:
    """Cylinder ``cylinder``: a free body, frame at its centre of mass on the axis, body z the
    axis; it rolls on its mid circle (``RollingContact`` with ``circle_z = 0``: the midpoint of
    the contact segment while the axis stays horizontal). Bar ``bar``: hinge child of the
    cylinder about its axis (body z) at the cylinder's centre, its frame at the pivot, its
    centre of mass at (0, -L/2, 0) (straight down at zero hinge angle and zero roll), in the
    cylinder's mid-plane.

    Initial state: the axis at (x0, 0, R) (m, world), zero roll; the bar at angle theta0 (rad)
    from the downward vertical, positive toward +x (pi/2: horizontal, Problem 5.13); rates
    dx0 (m/s, the axis's velocity along x) and dtheta0 (rad/s, the bar's absolute angular
    rate about world -y). Rolling without slip: the cylinder turns at dx0 / R about world +y,
    so the hinge rate is dtheta0 + dx0 / R.

    Raises InputError when the motion would need the plane to pull the cylinder down
    (``min_normal_force`` < 0: the bar whirled fast enough, or g = 0 with the bar moving): a
    rolling contact cannot pull, the ideal engines' bilateral one would."""
    M, m, R, L, h, a = (float(params[k]) for k in ("M", "m", "R", "L", "h", "a"))
    for key, value in (("M", M), ("m", m), ("R", R), ("L", L), ("h", h), ("a", a)):
        if not (np.isfinite(value) and value > 0.0):
            raise InputError(f"rolling_cylinder_bar: {key} = {value!r} must be positive")
    x0, theta0, dx0, dtheta0 = (float(params[k]) for k in ("x0", "theta0", "dx0", "dtheta0"))
    N_min, at = min_normal_force(M, m, R, L, a, float(params["g"]), theta0, dx0, dtheta0)
    if N_min < 0.0:
        raise InputError(f"rolling_cylinder_bar: the bar's swing would lift the cylinder off the plane (normal force "
                         f"{N_min:.3g} N at bar angle {at:.3g} rad): rolling needs a normal force >= 0 throughout")
    cylinder = Body("cylinder", None, "free", np.zeros(3), np.zeros(3), M, np.zeros(3), cylinder_inertia(M, R, h))
    bar = Body("bar", "cylinder", "hinge", np.zeros(3), HINGE_AXIS, m, np.array([0.0, -0.5 * L, 0.0]), bar_inertia(m, L, a))
    w_cyl_W = np.array([0.0, dx0 / R, 0.0])  # rolling without slip: v_A + w x (0, 0, -R) = 0
    q0 = {"cylinder": np.concatenate([[x0, 0.0, R], rotations.from_matrix(R_CYLINDER0)]),
          "bar": np.array([theta0])}
    v0 = {"cylinder": np.concatenate([[dx0, 0.0, 0.0], R_CYLINDER0.T @ w_cyl_W]),
          "bar": np.array([dtheta0 + dx0 / R])}
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=(cylinder, bar), gravity_W=gravity, q0=q0, v0=v0,
                     contacts=(RollingContact("cylinder", R, h, circle_z=0.0),))
