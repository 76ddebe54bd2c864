"""four_bar_chain: N four-bar windows side by side (IFToMM benchmark A02, the N four-bar
mechanism), a generated multibody: the builder repeats one window N times, and the scene's MJCF
and URDF are written from the built system (``generated = true`` in its ``scene.toml``;
``harness.model.model_files``).

Geometry (SI units). The chain moves in the world x-z plane (gravity -g z); every hinge axis is
world -y, so a positive angle turns +x toward +z. Bars are uniform solid cylinders of length L,
mass m and radius r along their body +x axis, body frames at their proximal joint:

* ``crank_<i>``, i = 0 .. N: hinged to the world at (i L, 0, 0), absolute angle theta_i;
* ``coupler_<i>``, i = 0 .. N-1: hinged to the tip of ``crank_<i>`` (joint coordinate: its
  absolute angle minus theta_i);
* the cut hinge ``cut_<i>`` joins the tip of ``coupler_<i>`` and the tip of ``crank_<i+1>``:
  window i is crank i, coupler i, crank i+1 and the ground between their pivots.

<i> has the digits of N (``crank_00`` .. ``crank_40``), so that the names sort as the bodies
stand.

With every bar and the pivots' spacing of one length, each window closes as a parallelogram at
every crank angle: the couplers stay parallel to the ground and every crank turns at one angle
theta (the motion of ``harness.references.four_bar_chain``). The initial state is that
parallelogram at theta0, turning at dtheta0: A02's is theta0 = pi/2 (the cranks upright) and
dtheta0 = -1 rad/s (the first crank's tip B0 moving at 1 m/s along +x).
"""

from __future__ import annotations

import numpy as np

from harness.model.builders.four_bar import AXIS, bar_inertia
from harness.model.errors import InputError
from harness.model.multibody import Body, LoopJoint, Multibody

MAX_WINDOWS = 1000  # 2N+1 bodies and N cut hinges: 2001 bodies is far beyond any engine's comfort here


def windows(params: dict) -> int:
    """N, the number of windows: a whole number from 1 to ``MAX_WINDOWS`` (InputError otherwise)."""
    n = float(params["N"])
    if n != round(n) or not 1 <= n <= MAX_WINDOWS:
        raise InputError(f"four_bar_chain: N (the number of windows) must be a whole number from 1 to {MAX_WINDOWS}, "
                         f"got {n:g}")
    return int(round(n))


def crank(i: int, n: int) -> str:
    """The name of crank i of a chain of n windows: its number padded to the digits of n, so
    that names sort as the bodies stand (MuJoCo orders a URDF's links by name)."""
    return f"crank_{i:0{len(str(n))}d}"


def coupler(i: int, n: int) -> str:
    """The name of coupler i of a chain of n windows (padded as ``crank``)."""
    return f"coupler_{i:0{len(str(n))}d}"


def build(params: dict) -> Multibody:
    n = windows(params)
    L, m, r = (float(params[k]) for k in ("L", "m", "r"))
    theta0, dtheta0 = float(params["theta0"]), float(params["dtheta0"])
    tip = np.array([L, 0.0, 0.0])
    com = 0.5 * tip
    inertia = bar_inertia(m, L, r)

    bodies, q0, v0, loops = [], {}, {}, []
    for i in range(n + 1):
        here = crank(i, n)
        bodies.append(Body(here, None, "hinge", np.array([i * L, 0.0, 0.0]), AXIS, m, com, inertia))
        q0[here], v0[here] = np.array([theta0]), np.array([dtheta0])
        if i == n:
            break
        # the window's coupler on this crank's tip, parallel to the ground (absolute angle 0)
        on = coupler(i, n)
        bodies.append(Body(on, here, "hinge", tip, AXIS, m, com, inertia))
        q0[on], v0[on] = np.array([-theta0]), np.array([-dtheta0])
        loops.append(LoopJoint(f"cut_{i:0{len(str(n))}d}", "hinge", on, crank(i + 1, n), tip, tip, AXIS, AXIS,
                               hinge_span=L))
    gravity = np.array([0.0, 0.0, -float(params["g"])])
    return Multibody(bodies=tuple(bodies), gravity_W=gravity, q0=q0, v0=v0, loops=tuple(loops))
